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

On a shared machine the 2-worker speedup measures the other processes as much as the
sweep. CPU time does not: ``local_{1,2}_worker_cpu_ms_per_point`` is the CPU of the
worker processes per point (all of it, pickling included), ``parent_cpu_ms_per_point``
the sweep process's while points run (dispatch, journal), ``serial_cpu_s`` its CPU
outside that (the folder, the tasks, the table and aggregates at the end; its wall
time is ``serial_wall_s``) and ``amdahl_2_workers`` the speedup these imply on two
otherwise idle cores::

    T1 = serial + N w,   T2 = serial + w + ((N - 1) w2 + N p) / 2

(``w``, ``w2`` the worker CPU a point with one and with two workers -- two busy
cores share caches and memory, so ``w2`` is a few per cent larger --, ``p`` the
parent's, ``serial`` its serial CPU; the first point runs alone, as a probe; on
two cores the sweep process takes its share from the workers).
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


def _process_cpu_s(pid):
    """User + system CPU seconds of process ``pid`` so far (Linux ``/proc``), or NaN."""
    import os

    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
    except OSError:
        return float("nan")
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _self_cpu_s():
    import resource

    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


class _DispatchClock:
    """Wall and CPU time of this process inside the sweep's dispatch loop (the points
    running), against the whole sweep: what is left is the serial part (the folder,
    the tasks, the table and aggregates)."""

    def __init__(self):
        from inins.sweep import engine

        self.engine, self.wall_s, self.cpu_s = engine, 0.0, 0.0
        self.original = engine._dispatch

    def __enter__(self):
        def timed(*args, **kwargs):
            wall, cpu = time.perf_counter(), _self_cpu_s()
            try:
                return self.original(*args, **kwargs)
            finally:
                self.wall_s += time.perf_counter() - wall
                self.cpu_s += _self_cpu_s() - cpu

        self.engine._dispatch = timed
        return self

    def __exit__(self, *exc):
        self.engine._dispatch = self.original
        return False


def _timed_sweep(folder, name, sweep, executor, cpu=None):
    """Wall time, worker busy share and CPU share of one sweep; with a dict ``cpu``,
    also the CPU seconds of the workers (``workers_s``), of this process while points
    run (``dispatch_cpu_s``) and outside that (``serial_cpu_s``, ``serial_wall_s``)."""
    from inins.sweep.engine import run_sweep
    from inins.sweep.plan import load_sweep

    plan = load_sweep(sweep)
    pids = list(getattr(executor.pool, "_processes", None) or ()) if cpu is not None else []
    workers_before = sum(_process_cpu_s(pid) for pid in pids)
    parent_before = _self_cpu_s()
    with _DispatchClock() as clock:
        start = time.perf_counter()
        outcome = run_sweep(plan, Path(folder) / name, executor)
        wall = time.perf_counter() - start
    if outcome.errors:
        raise RuntimeError(f"{outcome.errors} points raised in {name}")
    busy = sum(r["run_s"] for r in outcome.table.records)
    point_cpu = sum(r["cpu_s"] for r in outcome.table.records)
    if cpu is not None:
        cpu["workers_s"] = sum(_process_cpu_s(pid) for pid in pids) - workers_before
        cpu["dispatch_cpu_s"] = clock.cpu_s
        cpu["serial_cpu_s"] = _self_cpu_s() - parent_before - clock.cpu_s
        cpu["serial_wall_s"] = wall - clock.wall_s
    return wall, busy / (wall * executor.slots), point_cpu / (wall * executor.slots)


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
    used = {}
    for workers in (1, 2):
        executor = LocalExecutor(workers, "calibrate-bias", keep_open=True)
        used[workers] = {}
        try:
            _timed_sweep(folder, f"warm-{workers}", warm, executor)
            wall, busy, cpu = _timed_sweep(
                folder, f"local-{workers}", sweep, executor, used[workers]
            )
        finally:
            executor.close()
        figures[f"local_{workers}_points_per_s"] = points / wall
        figures[f"local_{workers}_worker_busy"] = busy
        figures[f"local_{workers}_worker_cpu_share"] = cpu
        figures[f"local_{workers}_worker_cpu_ms_per_point"] = (
            1e3 * used[workers]["workers_s"] / points
        )
    figures["speedup_2_workers"] = figures["local_2_points_per_s"] / figures["local_1_points_per_s"]
    # Amdahl on two idle cores, from CPU times (module docstring)
    w = used[1]["workers_s"] / points
    w2 = used[2]["workers_s"] / points  # a point on each core costs a little more
    p = used[1]["dispatch_cpu_s"] / points
    serial = used[1]["serial_cpu_s"]  # the probe point, run alone, is the "+ w" of T2
    t1 = serial + points * w
    t2 = serial + w + ((points - 1) * w2 + points * p) / 2.0
    figures["parent_cpu_ms_per_point"] = 1e3 * p
    figures["serial_cpu_s"] = serial
    figures["serial_wall_s"] = used[1]["serial_wall_s"]
    figures["serial_fraction_1_worker"] = serial / t1
    figures["amdahl_2_workers"] = t1 / t2
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
