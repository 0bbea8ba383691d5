"""Throughput of :func:`inins.core.imu.apply_errors` with every error term on.

``run()`` times one call on 7.2 million samples (2 h at 1 kHz) after a JIT
warm-up (three times), then the same record in 100 000-sample chunks (the streaming path),
and reports samples/s and the peak resident set size of the process.
"""

import resource
import sys
import time

import numpy as np

from inins.core import imu
from inins.core.units import DEG_RTH, DPH, DPS, MG, PPM, UG, UG_RTHZ, UG_S

N_SAMPLES = 7_200_000
DT = 1e-3
CHUNK = 100_000
REPEAT = 3


def all_terms_on():
    """A navigation-grade RLG IMU with every term of the model non-zero."""
    return imu.SensorErrors(
        gyro_bias=[0.01 * DPH, -0.02 * DPH, 0.005 * DPH],
        gyro_scale=[5 * PPM, -3 * PPM, 2 * PPM],
        gyro_misalignment=np.array([1.0, -2.0, 3.0, -1.5, 2.5, 0.5]) * 1e-5,
        accel_bias=[50 * UG, -30 * UG, 100 * UG],
        accel_scale=[50 * PPM, -40 * PPM, 30 * PPM],
        accel_misalignment=[2e-5, -1e-5, 3e-5],
        gyro_arw=0.002 * DEG_RTH,
        accel_vrw=20 * UG_RTHZ,
        gyro_bias_instability=0.003 * DPH,
        gyro_bias_corr_time_s=3600.0,
        accel_bias_instability=10 * UG,
        accel_bias_corr_time_s=1800.0,
        gyro_temp_sensitivity=0.001 * DPH,
        accel_temp_sensitivity=10 * UG,
        gyro_pulse_weight=1.5e-6,
        accel_pulse_weight=1 * UG_S,
    )


def _inputs(n):
    """Table spinning at 10 deg/s about z with gravity on z, and a slow temperature ramp."""
    dtheta = np.zeros((n, 3))
    dtheta[:, 2] = 10 * DPS * DT
    dv = np.zeros((n, 3))
    dv[:, 2] = -9.80665 * DT
    dv[:, 0] = 1 * MG * DT
    temperature = np.linspace(0.0, 0.5, n)
    return dtheta, dv, temperature


def _peak_rss_mb():
    scale = 1024.0 if sys.platform != "darwin" else 1024.0**2  # ru_maxrss: KiB (bytes on macOS)
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / scale


def run(quick=False):
    """Time :func:`apply_errors` on 2 h at 1 kHz with all terms on (``quick``: without
    the chunked pass).

    Returns
    -------
    dict
        ``n_samples``; ``single_call_first_s`` and ``single_call_best_s`` (one call
        on the whole record, first and best of three: the first pays for faulting
        in ~700 MB of fresh output pages); ``samples_per_s`` (best single call);
        ``chunked_s`` and ``chunked_samples_per_s`` (100 000-sample chunks),
        ``jit_warmup_s`` (first call, includes compile or cache load) and
        ``peak_rss_mb`` (whole process).
    """
    errors = all_terms_on()
    dtheta, dv, temperature = _inputs(N_SAMPLES)
    t0 = time.perf_counter()
    imu.apply_errors(
        dtheta[:1000],
        dv[:1000],
        DT,
        errors,
        np.random.default_rng(0),
        temperature_delta=temperature[:1000],
    )
    warmup = time.perf_counter() - t0

    singles = []
    for _ in range(REPEAT):
        rng = np.random.default_rng(1)
        t0 = time.perf_counter()
        out = imu.apply_errors(dtheta, dv, DT, errors, rng, temperature_delta=temperature)
        singles.append(time.perf_counter() - t0)
        del out

    figures = {
        "n_samples": N_SAMPLES,
        "jit_warmup_s": warmup,
        "single_call_first_s": singles[0],
        "single_call_best_s": min(singles),
        "samples_per_s": N_SAMPLES / min(singles),
        "peak_rss_mb": _peak_rss_mb(),
    }
    if quick:
        return figures
    rng = np.random.default_rng(1)
    state = None
    t0 = time.perf_counter()
    for start in range(0, N_SAMPLES, CHUNK):
        part = slice(start, start + CHUNK)
        *_, state, _ = imu.apply_errors(
            dtheta[part], dv[part], DT, errors, rng, state, temperature_delta=temperature[part]
        )
    chunked = time.perf_counter() - t0
    return {**figures, "chunked_s": chunked, "chunked_samples_per_s": N_SAMPLES / chunked}


if __name__ == "__main__":
    for key, value in run().items():
        print(f"{key:>24}: {value:,.3f}" if isinstance(value, float) else f"{key:>24}: {value}")
