"""Sweep throughput: per-point overhead, 2 local workers against 1, Dask against local.

``python -m benchmarks.bench_sweep [--points N]`` prints the figures as JSON.

- ``overhead_ms``: wall time per point of a 1-worker sweep of a scenario that does
  almost nothing (simulate-table, 1 s at 10 Hz), minus the time of the command's
  ``run`` alone in this process: dispatch to the worker, scenario loading and
  validation, checks, summary, journal and the table. Target < 20 ms.
- ``speedup_2_workers``: throughput of N points (default 1,000) of a short
  calibrate-bias scenario on 2 local workers over 1 worker. Target >= 1.8.
- ``dask_over_local``: the same N points on a Dask cluster of 2 single-thread worker
  processes on loopback, over 2 local workers. Target >= 0.8.

``*_worker_busy`` is the share of the workers' wall time spent inside points (the
sum of the points' run times over wall time x workers): near 1 means the dispatch
keeps every worker fed, so a speedup short of the worker count comes from the
machine (other processes on the cores), not from the sweep. The load average
before and after is reported with the figures. ``*_worker_cpu_share`` is the CPU
time the workers got inside points over wall time x workers: on an idle machine
near 1; on a shared one it shows the cores other processes took.

Every executor is warmed first (workers started, compiled kernels loaded), so the
figures are steady-state throughput; a sweep's start-up (a few seconds per worker)
is reported apart as ``local_start_s``.
"""

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import yaml

HERE = Path(__file__).parent
NEAR_EMPTY = HERE / "scenarios" / "sweep-near-empty.yaml"
SHORT_CAL = HERE / "scenarios" / "sweep-calibrate-short.yaml"


def _sweep_file(folder, command, base, seeds):
    path = Path(folder) / f"{command}-{seeds}.yaml"
    content = {"command": command, "base": str(base), "seeds": {"start": 100, "count": seeds}}
    path.write_text(yaml.safe_dump(content))
    return path


def _timed_sweep(folder, name, sweep, executor):
    from inins.sweep.engine import run_sweep
    from inins.sweep.plan import load_sweep

    plan = load_sweep(sweep)
    start = time.perf_counter()
    outcome = run_sweep(plan, Path(folder) / name, executor)
    wall = time.perf_counter() - start
    if outcome.errors:
        raise RuntimeError(f"{outcome.errors} points raised in {name}")
    busy = sum(r["run_s"] for r in outcome.table.records)
    cpu = sum(r["cpu_s"] for r in outcome.table.records)
    return wall, busy / (wall * executor.slots), cpu / (wall * executor.slots)


def _run_alone_ms(base, command, repeats=40):
    from inins.commands import find_command
    from inins.commands.execute import load

    module, loaded = load(find_command(command), base)
    module.run(loaded.model, 0)
    times = []
    for seed in range(repeats):
        start = time.perf_counter()
        module.run(loaded.model, seed)
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def _overhead(folder, points=300):
    from inins.sweep.executors import LocalExecutor

    run_ms = _run_alone_ms(NEAR_EMPTY, "simulate-table")
    executor = LocalExecutor(1, "simulate-table", keep_open=True)
    try:
        start = time.perf_counter()
        _timed_sweep(
            folder, "warm-empty", _sweep_file(folder, "simulate-table", NEAR_EMPTY, 2), executor
        )
        local_start = time.perf_counter() - start
        sweep = _sweep_file(folder, "simulate-table", NEAR_EMPTY, points)
        wall, _, _ = _timed_sweep(folder, "empty", sweep, executor)
    finally:
        executor.close()
    per_point_ms = 1e3 * wall / points
    return {
        "points": points,
        "run_alone_ms": run_ms,
        "sweep_per_point_ms": per_point_ms,
        "overhead_ms": per_point_ms - run_ms,
        "local_start_s": local_start,
    }


def _throughput(folder, points):
    from inins.sweep.executors import LocalExecutor

    sweep = _sweep_file(folder, "calibrate-bias", SHORT_CAL, points)
    warm = _sweep_file(folder, "calibrate-bias", SHORT_CAL, 4)
    figures = {"points": points}
    for workers in (1, 2):
        executor = LocalExecutor(workers, "calibrate-bias", keep_open=True)
        try:
            _timed_sweep(folder, f"warm-{workers}", warm, executor)
            wall, busy, cpu = _timed_sweep(folder, f"local-{workers}", sweep, executor)
        finally:
            executor.close()
        figures[f"local_{workers}_points_per_s"] = points / wall
        figures[f"local_{workers}_worker_busy"] = busy
        figures[f"local_{workers}_worker_cpu_share"] = cpu
    figures["speedup_2_workers"] = figures["local_2_points_per_s"] / figures["local_1_points_per_s"]
    dask = _dask(folder, sweep, warm, points)
    if dask is not None:
        keys = ("dask_2_points_per_s", "dask_2_worker_busy", "dask_2_worker_cpu_share")
        figures.update(zip(keys, dask, strict=True))
        figures["dask_over_local"] = dask[0] / figures["local_2_points_per_s"]
    return figures


def _dask(folder, sweep, warm, points):
    try:
        import distributed
    except ImportError:
        return None
    import dask

    from inins.sweep.executors import DaskExecutor

    # workers as the README starts them: without the statistical profiler, which
    # samples every thread every 10 ms (several % of a core on a busy worker)
    with (
        dask.config.set({"distributed.worker.profile.enabled": False}),
        distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            silence_logs=50,
        ) as cluster,
    ):
        address = cluster.scheduler_address
        _timed_sweep(folder, "warm-dask", warm, DaskExecutor(address, "calibrate-bias"))
        wall, busy, cpu = _timed_sweep(
            folder, "dask", sweep, DaskExecutor(address, "calibrate-bias")
        )
    return points / wall, busy, cpu


def run(points: int = 1000, quick: bool = False) -> dict:
    """All sweep figures (see the module docstring); ``quick``: the overhead only."""
    import os

    figures = {"load_average_1min_before": os.getloadavg()[0], "cores": os.cpu_count()}
    with tempfile.TemporaryDirectory() as folder:
        figures["overhead"] = _overhead(folder)
        if not quick:
            figures["throughput"] = _throughput(folder, points)
    figures["load_average_1min_after"] = os.getloadavg()[0]
    return figures


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_sweep")
    parser.add_argument("--points", type=int, default=1000)
    args = parser.parse_args(argv)
    json.dump(run(args.points), sys.stdout, indent=2)
    print()


if __name__ == "__main__":
    main()
