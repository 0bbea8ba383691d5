"""Tightly coupled EKF speed and memory (issue 11): EKF2 (26 states), feedback, 1 h and 4 h.

``run()`` simulates one hour of a bank-turn flight (200 Hz IMU with the sensor
error model and RLG dither, 1 Hz pseudoranges and range rates from the nominal
Walker constellation 30/6/1 of :func:`inins.gnss.constellation.walker` through the
GNSS layer's receiver simulation, :func:`inins.ekf.sources.simulated_epochs`: 8-12
satellites above 5 deg),
warms the JIT up, then times :func:`inins.ekf.filter.run_filter` over the
stored hour (target < 2 s, >= 1800x real time) and reports the per-epoch cost.
A child process then streams a 4-hour flight through the filter (simulation
and filter chunk by chunk) and reports its peak RSS (target < 1 GB, flat in
flight length: the 1-hour child figure is given beside it).

Issue 23 figures: the simulation of one hour of epochs (truth trajectory, IMU
stream, receiver; 1 h and 4 h for linearity), the filter alone, the scoring
against truth after the run, and the whole process ``inins run-ekf`` on the
one-hour scenario ``benchmarks/scenarios/run-ekf-1h.yaml`` (EKF2-FB, 200 Hz,
ABPO constellation), warm (the second of two runs).

Run alone: ``python -m benchmarks.bench_ekf`` (``--rss-hours H`` runs one
streamed flight of H hours and prints its peak RSS). ``--before REPO --before-python
PY`` also measures the same figures on another checkout of inins (e.g. the main
branch with its own environment) and prints them side by side.
"""

# ruff: noqa: E402  (the BLAS threads are pinned before the imports load numpy)

import os

# the CLI's setting (inins.cli.main): one BLAS thread for the 26 x 26 products, set
# before numpy loads, so that the filter is timed as a command runs it
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from inins.core import imu, strapdown
from inins.core.units import ARCSEC, DEG, DEG_RTH, DPH, UG
from inins.ekf.config import Coupling, EpochInput, FilterConfig, InitialSigma, Model
from inins.ekf.filter import run_filter
from inins.ekf.flight import (
    Dither,
    Dithered,
    FlightPlan,
    Leg,
    LegKind,
    dither_window,
    flight_trajectory,
    gyrocompass_attitude,
)
from inins.ekf.sources import Receiver, simulated_epochs
from inins.gnss import constellation, gpstime

ROOT = Path(__file__).resolve().parent.parent
if __name__ == "__main__" and "benchmarks" not in sys.modules and not os.environ.get("PYTHONPATH"):
    sys.path.insert(0, str(ROOT))  # run as a script: this checkout (--before: PYTHONPATH's)

DT = 0.005
ERRORS = imu.SensorErrors(
    gyro_bias=np.array([0.01, -0.01, 0.0]) * DPH,
    accel_bias=np.array([50, -40, 30]) * UG,
    gyro_misalignment=np.array([-30, 20, 50, 200, -40, 200]) * 1e-6,
    accel_misalignment=np.array([20, -30, 10]) * 1e-6,
    gyro_arw=0.002 * DEG_RTH,
    accel_vrw=20 * UG,
)
DITHER = Dither(60 * ARCSEC, 40.0)
RECEIVER = Receiver(
    lever_arm=(1.5, 0.2, -1.0),
    mask=5 * DEG,
    sigma_pr=2.0,
    sigma_rr=0.05,
    h0=2e-19,
    h_2=2e-20,
    clock_bias=3000.0,
    clock_drift=0.5,
    latency=0.15,
    filter_sigma_pr=2.0,
    filter_sigma_rr=0.05,
)


def _plan(hours):
    """Wait, take-off, climb, then blocks of alternating 360-deg turns, climbs and descents."""
    legs = [
        Leg(LegKind.WAIT, 120),
        Leg(LegKind.TAKEOFF, 40, speed=80.0),
        Leg(LegKind.CLIMB, 100, climb_rate=5.0),
    ]
    pattern = [
        Leg(LegKind.STRAIGHT, 60),
        Leg(LegKind.TURN, bank=30 * DEG, angle=360 * DEG),
        Leg(LegKind.CLIMB, 60, climb_rate=4.0),
        Leg(LegKind.TURN, bank=25 * DEG, angle=-360 * DEG),
        Leg(LegKind.CLIMB, 60, climb_rate=-4.0),
    ]
    plan = FlightPlan(37 * DEG, 127 * DEG, 100.0, 180 * DEG, tuple(legs))
    while plan.duration < 3600.0 * hours + 60.0:
        plan = FlightPlan(37 * DEG, 127 * DEG, 100.0, 180 * DEG, plan.legs + tuple(pattern))
    return plan


def _setup(hours, truth=False):
    plan = _plan(hours)
    base = flight_trajectory(plan)
    truth = Dithered(base, DITHER)
    mat0, vel0, lla0 = truth.state([0.0])
    mat_base, _, _ = base.state([0.0])
    aligned = gyrocompass_attitude(mat_base[0], lla0[0, 0], lla0[0, 2], ERRORS)
    initial = strapdown.NavState.from_attitude(aligned @ mat_base[0].T @ mat0[0], vel0[0], lla0[0])
    config = FilterConfig(
        Model.EKF2,
        Coupling.FB,
        DT,
        lever_arm=RECEIVER.lever_arm,
        arw=np.full(3, 0.002 * DEG_RTH),
        vrw=np.full(3, 20 * UG),
        dither_window=dither_window(DITHER, DT),
        initial_sigma=InitialSigma(heading=0.1 * DEG, gyro_bias=0.02 * DPH, clock_bias=1e4),
    )
    week, sow0 = gpstime.from_calendar(2015, 1, 8, 6, 0, 0.0)
    duration = 3600.0 * hours
    eph = constellation.walker(week, sow0, duration + 60.0, per_plane=5)  # 30/6/1
    stream = simulated_epochs(
        truth, base, ERRORS, DT, duration, eph, week, sow0, RECEIVER, seed=5, nodes=2
    )
    if not truth:  # the filter's own cost: no truth comparison
        stream = (EpochInput(e.dtheta, e.dv, e.pps_index, e.gnss) for e in stream)
    return config, initial, stream


def _peak_rss_mb():
    scale = 1.0 if sys.platform == "darwin" else 1024.0
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale / 2**20


def _streamed(hours):
    """Peak RSS (MB) of one streamed flight of ``hours`` in a child process."""
    code = [sys.executable, "-m", "benchmarks.bench_ekf", "--rss-hours", str(hours)]
    out = subprocess.run(code, check=True, capture_output=True, text=True, cwd=ROOT)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _simulation_s(hours):
    """Wall and CPU time (s) of producing every epoch of a flight of ``hours`` (no filter),
    and the number of epochs."""
    _, _, stream = _setup(hours, truth=True)
    wall, cpu = time.perf_counter(), time.process_time()
    count = sum(1 for _ in stream)
    return time.perf_counter() - wall, time.process_time() - cpu, count


def _children_cpu():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _process_s(scenario, python=sys.executable, cwd=ROOT, repeat=2):
    """Whole-process wall and CPU time (s) of ``inins run-ekf scenario``: medians of the
    warm runs (the first of ``repeat + 1`` loads the JIT cache and is dropped)."""
    walls, cpus = [], []
    with tempfile.TemporaryDirectory() as out:
        for i in range(repeat + 1):
            wall, cpu = time.perf_counter(), _children_cpu()
            subprocess.run(
                [python, "-m", "inins", "run-ekf", str(scenario), "-o", f"{out}/{i}"],
                check=True,
                capture_output=True,
                cwd=cwd,
            )
            walls.append(time.perf_counter() - wall)
            cpus.append(_children_cpu() - cpu)
    return statistics.median(walls[1:]), statistics.median(cpus[1:])


def _best(func, repeat=3):
    """Least wall and least CPU time (s) of ``repeat`` calls of ``func``."""
    walls, cpus = [], []
    for _ in range(repeat):
        wall, cpu = time.perf_counter(), time.process_time()
        func()
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
    return min(walls), min(cpus)


def figures(quick=False):
    """The issue-23 figures of this checkout (flat dict, wall and CPU seconds: on a shared
    machine the CPU figures are the comparable ones); ``quick``: no 4-h simulation."""
    config, initial, stream = _setup(1.0, truth=True)
    epochs = list(stream)
    bare = [EpochInput(e.dtheta, e.dv, e.pps_index, e.gnss) for e in epochs]
    run_filter(config, initial, 0.0, bare[:5])  # JIT warm-up
    alone = _best(lambda: run_filter(config, initial, 0.0, bare))
    scored = _best(lambda: run_filter(config, initial, 0.0, epochs, ERRORS))
    sim_1h = _simulation_s(1.0)
    out = {"hour_epochs": sim_1h[2]}
    for name, (wall, cpu) in (
        ("hour_filter_alone", alone),
        ("hour_truth_scoring", (scored[0] - alone[0], scored[1] - alone[1])),
        ("hour_simulation", sim_1h[:2]),
    ):
        out[f"{name}_s"], out[f"{name}_cpu_s"] = wall, cpu
    if not quick:
        sim_4h = _simulation_s(4.0)
        out["four_hour_simulation_s"], out["four_hour_simulation_cpu_s"] = sim_4h[:2]
        out["simulation_4h_over_1h_cpu"] = sim_4h[1] / sim_1h[1]
    scenario = ROOT / "benchmarks/scenarios/run-ekf-1h.yaml"
    wall, cpu = _process_s(scenario, cwd=Path.cwd())
    out["process_run_ekf_1h_warm_s"], out["process_run_ekf_1h_warm_cpu_s"] = wall, cpu
    return out


def run(quick=False):
    """Time one stored hour of EKF2-FB; stream 1 h and 4 h for peak RSS (``quick``: no
    streams). Flat dict of figures."""
    config, initial, stream = _setup(1.0)
    epochs = list(stream)
    start = time.perf_counter()
    run_filter(config, initial, 0.0, epochs[:5])
    warmup = time.perf_counter() - start
    walls, result = [], None
    for _ in range(3):
        start = time.perf_counter()
        result = run_filter(config, initial, 0.0, epochs)
        walls.append(time.perf_counter() - start)
    hour = min(walls)
    one = None if quick else _streamed(1.0)
    four = None if quick else _streamed(4.0)
    return {
        "jit_warmup_s": warmup,
        "hour_epochs": len(epochs),
        "hour_sats_mean": float(np.mean(result.n_sats)),
        "hour_sats_min": int(np.min(result.n_sats)),
        "hour_sats_max": int(np.max(result.n_sats)),
        "hour_ekf2_fb_s": hour,
        "hour_realtime_factor": 3600.0 / hour,
        "epoch_ms_mean": 1e3 * hour / len(epochs),
        "epoch_update_ms_mean": 1e3 * float(np.mean(result.update_time)),
        "epoch_update_ms_max": 1e3 * float(np.max(result.update_time)),
        **({} if one is None else {"stream_1h_peak_rss_mb": one["peak_rss_mb"]}),
        **(
            {}
            if four is None
            else {"stream_4h_peak_rss_mb": four["peak_rss_mb"], "stream_4h_wall_s": four["wall_s"]}
        ),
        **figures(quick),
    }


def _rss_child(hours):
    config, initial, stream = _setup(hours)
    start = time.perf_counter()
    result = run_filter(config, initial, 0.0, stream)
    figures = {
        "peak_rss_mb": _peak_rss_mb(),
        "wall_s": time.perf_counter() - start,
        "epochs": len(result.time),
        "coasted": int(result.summary().coasted_epochs),
    }
    print(json.dumps(figures))


def _before(repo, python, quick):
    """:func:`figures` of another checkout: this file's code run by its interpreter on its
    package (``PYTHONPATH=repo``)."""
    code = [python, str(Path(__file__).resolve()), "--figures"] + (["--quick"] if quick else [])
    env = dict(os.environ, PYTHONPATH=str(repo))
    out = subprocess.run(code, check=True, capture_output=True, text=True, cwd=repo, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _main():
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_ekf")
    parser.add_argument("--rss-hours", type=float, help="stream one flight, print peak RSS")
    parser.add_argument("--figures", action="store_true", help="print the issue-23 figures")
    parser.add_argument("--quick", action="store_true", help="no 4-h runs")
    parser.add_argument("--before", type=Path, help="another checkout of inins to compare")
    parser.add_argument("--before-python", default=sys.executable, help="its interpreter")
    args = parser.parse_args()
    if args.rss_hours:
        _rss_child(args.rss_hours)
        return
    if args.figures:
        print(json.dumps(figures(args.quick)))
        return
    after = figures(args.quick) if args.before else run(args.quick)
    if args.before is None:
        for key, value in after.items():
            print(f"{key:32s} {value:.6g}")
        return
    before = _before(args.before, args.before_python, args.quick)
    print(f"{'figure':32s} {'before':>12s} {'after':>12s}")
    for key, value in after.items():
        old = before.get(key, float("nan"))
        print(f"{key:32s} {old:12.4g} {value:12.4g}")


if __name__ == "__main__":
    _main()
