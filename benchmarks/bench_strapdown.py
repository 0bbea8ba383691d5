"""Strapdown integrator throughput and memory.

``run()`` warms up the JIT, times :func:`inins.core.strapdown.integrate` on one
hour of 200 Hz increments in one call, then integrates 24 h at 200 Hz in
1-minute chunks decimated to 1 Hz and reports the peak resident set size
(which must stay below 1 GB: memory grows with what is kept, not with the
record length).
"""

import resource
import sys
import time

import numpy as np

from inins.core import earth, rotation, strapdown
from inins.core.units import DEG, DPH, UG

RATE_HZ = 200.0
LAT, LON, HEIGHT = 37.0 * DEG, 127.0 * DEG, 100.0


def _increments(n, dt, seed=0):
    """Stationary increments at a tilted attitude plus white noise and biases."""
    mat_nb = rotation.mat_from_euler(0.01, -0.02, 1.0)
    omega_b = mat_nb.T @ earth.rate_ie_n(LAT) + 0.01 * DPH
    force_b = -mat_nb.T @ earth.gravity_n(LAT, HEIGHT) + 50.0 * UG
    rng = np.random.default_rng(seed)
    dtheta = omega_b * dt + 1e-7 * rng.standard_normal((n, 3))
    dv = force_b * dt + 1e-5 * rng.standard_normal((n, 3))
    return mat_nb, dtheta, dv


def _peak_rss_mb():
    scale = 1.0 if sys.platform == "darwin" else 1024.0  # bytes on macOS, KiB on Linux
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale / 2**20


def run():
    """Time the integrator; return a flat dict of figures (unit in each key)."""
    dt = 1.0 / RATE_HZ
    n_hour = int(3600 * RATE_HZ)
    mat_nb, dtheta, dv = _increments(n_hour, dt)
    state = strapdown.NavState.from_attitude(mat_nb, [0.0, 0.0, 0.0], [LAT, LON, HEIGHT])

    start = time.perf_counter()
    strapdown.integrate(state, dtheta[:10], dv[:10], dt)
    warmup = time.perf_counter() - start

    timings = []
    for _ in range(3):
        start = time.perf_counter()
        strapdown.integrate(state, dtheta, dv, dt, decimation=int(RATE_HZ))
        timings.append(time.perf_counter() - start)
    hour = min(timings)

    chunk = int(60 * RATE_HZ)
    minute_theta, minute_v = dtheta[:chunk].copy(), dv[:chunk].copy()
    del dtheta, dv
    kept, current = [], state
    start = time.perf_counter()
    for _ in range(24 * 60):
        current, series = strapdown.integrate(current, minute_theta, minute_v, dt,
                                              decimation=int(RATE_HZ))
        kept.append(series)
    day = time.perf_counter() - start
    joined = strapdown.NavSeries.concatenate(kept)
    return {
        "jit_warmup_s": warmup,
        "hour_200hz_samples": n_hour,
        "hour_200hz_s": hour,
        "hour_200hz_msamples_per_s": n_hour / hour / 1e6,
        "day_200hz_chunked_s": day,
        "day_200hz_msamples_per_s": current.count / day / 1e6,
        "day_outputs_1hz": len(joined),
        "peak_rss_mb": _peak_rss_mb(),
    }


if __name__ == "__main__":
    for key, value in run().items():
        print(f"{key:28s} {value:.6g}")
