"""Speed of the observability analysis (issue 12 targets).

``run()`` times, best of three after a warm-up (JIT cache load, first imports):

- the 26-state (EKF2) stripped observability matrix over 100 segments with
  pseudorange and range rate from six satellites, with rank, null space and
  singular values per segment (target < 0.2 s);
- the covariance analysis of one hour with updates at 1 Hz, 26 states
  (3600 predict + Joseph-update cycles; target < 1 s).

Both are chains of small-matrix operations (26 x 26, 52 x 52). A multi-threaded
OpenBLAS spends far longer handing such calls between threads than computing
them, and on a loaded machine (more busy processes than cores) the covariance
analysis took 5.4 s instead of 0.27 s. The module therefore pins the BLAS
threads of its own process to one before numpy loads (unless the caller set
them); a command running these analyses should do the same.
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import time  # noqa: E402

import numpy as np  # noqa: E402

from inins.core import rotation  # noqa: E402
from inins.core.units import DEG, DPH, MG  # noqa: E402
from inins.observability import covariance, models, pwcs  # noqa: E402
from inins.observability import measurements as meas  # noqa: E402
from inins.observability.segments import make_segment  # noqa: E402

REPEAT = 3
LOS = np.array(
    [
        [0.0, 0.0, -1.0],
        [0.5, 0.3, -0.8],
        [-0.4, 0.6, -0.6],
        [0.2, -0.7, -0.5],
        [-0.6, -0.5, -0.3],
        [0.7, -0.2, -0.4],
    ]
)
LOS = LOS / np.linalg.norm(LOS, axis=1)[:, None]
LEVER_B = (1.0, 0.0, -1.5)
MEASUREMENTS = (
    meas.Measurement("pseudorange", 3.0, lever_arm_b=LEVER_B, los_n=LOS),
    meas.Measurement("range_rate", 0.05, lever_arm_b=LEVER_B, los_n=LOS),
)


def manoeuvre(count, duration):
    """``count`` segments of ``duration`` s: heading steps, banks, pitch and speed changes."""
    rng = np.random.default_rng(7)
    segments = []
    for k in range(count):
        roll, pitch, heading = rng.uniform(-30, 30) * DEG, rng.uniform(-5, 10) * DEG, k * 0.4
        speed = rng.uniform(80.0, 200.0)
        vel = speed * np.array([np.cos(heading), np.sin(heading), -np.sin(pitch)])
        mat = rotation.mat_from_euler(roll, pitch, heading)
        f_b = np.array([rng.uniform(-1, 1), rng.uniform(-0.5, 0.5), -9.8 / np.cos(roll)])
        omega = rng.uniform(-0.05, 0.05, 3)
        segments.append(
            make_segment(
                duration,
                (37 * DEG, 127 * DEG, 2000.0),
                mat_nb=mat,
                vel_n=vel,
                f_b=f_b,
                omega_ib_b=omega,
            )
        )
    return segments


def _best(func):
    func()
    times = []
    for _ in range(REPEAT):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return min(times)


def run():
    """Wall times (s) of the two targets and the results they produced.

    Returns
    -------
    dict
        ``som_26x100_s`` (best of three), ``som_rank``; ``covariance_1h_1hz_s``
        (best of three), ``covariance_updates``; ``covariance_first_call_s``
        (includes loading the cached JIT kernel).
    """
    model = models.MODELS["ekf26"]
    segments = manoeuvre(100, 36.0)
    result = pwcs.analyse(model, segments, MEASUREMENTS)
    som = _best(lambda: pwcs.analyse(model, segments, MEASUREMENTS))
    sigma_0 = np.r_[
        [10.0] * 3, [0.5] * 3, [1 * DEG] * 3, [1 * MG] * 3, [1 * DPH] * 3, 100.0, 1.0, [1e-4] * 9
    ]
    noise = models.ProcessNoise(
        arw=0.002 * DEG / 60, vrw=1e-4, clock_bias_psd=0.1, clock_drift_psd=0.01
    )
    start = time.perf_counter()
    cov = covariance.analyse(model, segments, MEASUREMENTS, sigma_0, noise=noise, dt=1.0)
    first = time.perf_counter() - start
    best = _best(lambda: covariance.analyse(model, segments, MEASUREMENTS, sigma_0, noise=noise))
    return {
        "som_26x100_s": som,
        "som_rank": result.rank,
        "covariance_1h_1hz_s": best,
        "covariance_updates": len(cov.time) - 1,
        "covariance_first_call_s": first,
    }


if __name__ == "__main__":
    for key, value in run().items():
        print(f"{key:>26}: {value:.4f}" if isinstance(value, float) else f"{key:>26}: {value}")
