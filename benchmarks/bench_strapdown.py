"""Strapdown integrator throughput and memory, side by side with its previous kernel and pyins.

``run()`` warms up the JIT and times :func:`inins.core.strapdown.integrate` on one
hour of 200 Hz increments in one call with outputs at 1 Hz, in free navigation and
in fixed-position mode (best of three, CPU seconds, so that other processes on a
shared machine count less). On the same increments and in the same run it times
the previous kernel (the frozen copy ``tests/core/strapdown_v0.py``, when the
tests are there) and, when ``python-ins`` is installed, pyins' numba kernel
(outputs at every sample, no coning or sculling correction) and its pandas
``Integrator``; ``free_over_pyins_kernel`` compares the two kernels in calls taken
in turns (best of five each), so that a shared machine's load falls on both. Then
it integrates 24 h at 200 Hz in 1-minute chunks decimated to 1 Hz (CPU time: the
kernel plus about 40 us of Python per call) and reports the peak resident set size
(which must stay below 1 GB: memory grows with what is kept, not with the record
length).

Targets (issue 9): >= 12 M samples/s free, >= 20 M samples/s fixed position.
"""

import functools
import importlib
import resource
import sys
import time
from pathlib import Path

import numpy as np

from inins.core import earth, rotation, strapdown
from inins.core.units import DEG, DPH, UG

RATE_HZ = 200.0
LAT, LON, HEIGHT = 37.0 * DEG, 127.0 * DEG, 100.0
TESTS_CORE = Path(__file__).parents[1] / "tests" / "core"


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


def _best_cpu(func, repeat=3):
    """Smallest CPU time (s) of ``repeat`` calls of ``func()``."""
    times = []
    for _ in range(repeat):
        start = time.process_time()
        func()
        times.append(time.process_time() - start)
    return min(times)


def _previous_kernel():
    """The frozen previous kernel module, or None outside a source checkout."""
    if not (TESTS_CORE / "strapdown_v0.py").exists():
        return None
    sys.path.insert(0, str(TESTS_CORE))
    try:
        return importlib.import_module("strapdown_v0")
    finally:
        sys.path.remove(str(TESTS_CORE))


def _kernels(mat_nb, dtheta, dv, dt):
    """M samples/s of the current and previous kernels, free and fixed position."""
    state = strapdown.NavState.from_attitude(mat_nb, [0.0, 0.0, 0.0], [LAT, LON, HEIGHT])
    runs = {
        "": lambda **o: strapdown.integrate(state, dtheta, dv, dt, decimation=int(RATE_HZ), **o)
    }
    previous = _previous_kernel()
    if previous is not None:
        runs["previous_kernel_"] = lambda **o: previous.integrate(
            state.quat_nb, state.vel_n, state.lla, dtheta, dv, dt, decimation=int(RATE_HZ), **o
        )
    figures = {}
    for prefix, call in runs.items():
        call(fixed_position=False)  # compile or load from the cache
        for mode, options in (("free", {}), ("fixed", {"fixed_position": True})):
            seconds = _best_cpu(lambda c=call, o=options: c(**o))
            figures[f"{prefix}{mode}_hour_200hz_msamples_per_s"] = dtheta.shape[0] / seconds / 1e6
    return figures


def _pyins(mat_nb, dtheta, dv, dt):
    """M samples/s of pyins' numba kernel and Integrator on the same increments (if installed)."""
    try:
        import pandas as pd
        from pyins import strapdown as pyins_strapdown
        from pyins import transform
        from pyins._numba_integrate import integrate as pyins_kernel
    except ImportError:
        return None
    n = dtheta.shape[0]
    dts = np.full(n, dt)
    lla, vel, mats = np.empty((n + 1, 3)), np.zeros((n + 1, 3)), np.empty((n + 1, 3, 3))
    lla[0], mats[0] = [np.degrees(LAT), np.degrees(LON), HEIGHT], mat_nb
    pyins_kernel(dts[:10], lla, vel, mats, dtheta[:10], dv[:10], 0, True)  # compile
    theirs = functools.partial(pyins_kernel, dts, lla, vel, mats, dtheta, dv, 0, True)
    kernel = _best_cpu(theirs)
    roll, pitch, heading = transform.mat_to_rph(mat_nb)
    pva = pd.Series(
        {
            "lat": np.degrees(LAT),
            "lon": np.degrees(LON),
            "alt": HEIGHT,
            "VN": 0.0,
            "VE": 0.0,
            "VD": 0.0,
            "roll": roll,
            "pitch": pitch,
            "heading": heading,
        }
    )
    columns = {"dt": dts} | {f"theta_{a}": dtheta[:, i] for i, a in enumerate("xyz")}
    columns |= {f"dv_{a}": dv[:, i] for i, a in enumerate("xyz")}
    increments = pd.DataFrame(columns, index=pd.Index(np.arange(1, n + 1) * dt, name="time"))
    integrator = _best_cpu(lambda: pyins_strapdown.Integrator(pva).integrate(increments), repeat=1)
    return {
        "pyins_kernel_free_msamples_per_s": n / kernel / 1e6,
        "pyins_integrator_free_msamples_per_s": n / integrator / 1e6,
    }, theirs


def _interleaved_ratio(ours, theirs, rounds=5):
    """pyins' kernel time over ours, each the best of ``rounds`` calls taken in turns
    (on a shared machine both then see the same load)."""
    mine, other = [], []
    for _ in range(rounds):
        mine.append(_best_cpu(ours, repeat=1))
        other.append(_best_cpu(theirs, repeat=1))
    return min(other) / min(mine)


def run():
    """Time the integrator; return a flat dict of figures (unit in each key)."""
    dt = 1.0 / RATE_HZ
    n_hour = int(3600 * RATE_HZ)
    mat_nb, dtheta, dv = _increments(n_hour, dt)
    state = strapdown.NavState.from_attitude(mat_nb, [0.0, 0.0, 0.0], [LAT, LON, HEIGHT])

    start = time.perf_counter()
    strapdown.integrate(state, dtheta[:10], dv[:10], dt)
    warmup = time.perf_counter() - start
    figures = {"jit_warmup_s": warmup, "hour_200hz_samples": n_hour}
    figures |= _kernels(mat_nb, dtheta, dv, dt)
    pyins = _pyins(mat_nb, dtheta, dv, dt)
    if pyins:  # the yardstick: >= 5, from runs in turns
        figures |= pyins[0]
        figures["free_over_pyins_kernel"] = _interleaved_ratio(
            functools.partial(strapdown.integrate, state, dtheta, dv, dt, decimation=int(RATE_HZ)),
            pyins[1],
        )

    chunk = int(60 * RATE_HZ)
    minute_theta, minute_v = dtheta[:chunk].copy(), dv[:chunk].copy()
    del dtheta, dv
    kept, current = [], state
    start = time.process_time()
    for _ in range(24 * 60):
        current, series = strapdown.integrate(
            current, minute_theta, minute_v, dt, decimation=int(RATE_HZ)
        )
        kept.append(series)
    day = time.process_time() - start
    joined = strapdown.NavSeries.concatenate(kept)
    return figures | {
        "day_200hz_chunked_cpu_s": day,
        "day_200hz_msamples_per_s": current.count / day / 1e6,
        "day_outputs_1hz": len(joined),
        "peak_rss_mb": _peak_rss_mb(),
    }


if __name__ == "__main__":
    for key, value in run().items():
        print(f"{key:44s} {value:.6g}")
