"""First-run cost: numba compile time of every kernel from a cold cache.

Each measurement runs in a child process whose ``NUMBA_CACHE_DIR`` is a fresh
temporary directory, so the real on-disk cache (``__pycache__`` next to the
sources) is never read, written or destroyed. The child listens to numba's
``numba:compile`` events (emitted only for a real compilation, never for a cache
load) and runs one command with its shipped scenario: ``calibrate-bias`` (which
simulates its table record first) or ``simulate-table``, each on its own empty
cache. A second child on the cache the first one filled gives the warm figures.

Per kernel it reports the *exclusive* compile time in CPU seconds (its own
typing, lowering and LLVM optimisation; the kernels it calls, compiled while it
is typed, are counted under their own names; CPU time, so that other processes on
a shared machine do not inflate it) and the number of specialisations. First-run
and warm-run figures are whole processes (interpreter, imports, compile or cache
load, the command), wall and CPU.

Then the modules' ``warm_up()`` functions (:data:`WARM_UP`, what an install step
would call) run on a fresh cache, and each command runs on the cache they filled:
it should compile nothing (``*_after_warm_up_compiled``).

``run()`` (``make bench``) measures the working tree. Run as a script,
``python -m benchmarks.bench_compile --against REV`` also measures the tree of
git revision ``REV`` (exported to a temporary directory) in the same run and
prints both side by side::

    python -m benchmarks.bench_compile --against 6ee7f1a
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).parent
ROOT = HERE.parent
WORKLOADS = (("calibrate-bias",), ("simulate-table",))
WARM_UP = ("inins.core.pulses", "inins.core.imu", "inins.core.strapdown", "inins.table.kinematics")
"""Modules whose ``warm_up()`` compiles every kernel of the commands (an install step)."""

_CHILD = r"""
import json, sys, time
start, start_cpu = time.perf_counter(), time.process_time()
from numba.core import event

stack, rows = [], []

class Listener(event.Listener):
    def on_start(self, ev):
        stack.append([ev.data["dispatcher"], time.process_time(), 0.0])

    def on_end(self, ev):
        disp, t0, children = stack.pop()
        total = time.process_time() - t0
        if stack:
            stack[-1][2] += total
        name = disp.py_func.__module__ + "." + disp.py_func.__qualname__
        rows.append((name, str(ev.data["args"]), total - children, total))

event.register("numba:compile", Listener())

phases = {}
for args in json.loads(sys.argv[1]):
    t0, c0 = time.perf_counter(), time.process_time()
    code = 0
    if args[0] == "warm-up":
        import importlib
        for module in args[1:]:
            importlib.import_module(module).warm_up()
    else:
        from inins.cli import app
        try:
            app(args=args, prog_name="inins")
        except SystemExit as exc:
            code = exc.code or 0
    phases[args[0]] = {"wall_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0,
                       "exit": code}
print(json.dumps({"wall_s": time.perf_counter() - start, "cpu_s": time.process_time() - start_cpu,
                  "phases": phases, "kernels": rows}))
"""


def _child(src, cache_dir, outdir, workload):
    """Run one workload in a child with its own numba cache; its JSON figures."""
    args = [
        list(workload)
        if workload[0] in ("warm-up", "warmup")
        else [*workload, "-o", str(Path(outdir) / workload[0])]
    ]
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), PYTHONPATH=str(src))
    start = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, json.dumps(args)],
        env=env,
        cwd=src,
        capture_output=True,
        text=True,
    )
    wall = time.perf_counter() - start
    if out.returncode != 0:
        raise RuntimeError(f"compile bench child failed:\n{out.stderr[-4000:]}")
    figures = json.loads(out.stdout.strip().splitlines()[-1])
    figures["process_wall_s"] = wall
    return figures


def measure(src=ROOT, warm_up=True):
    """Cold-cache and warm-cache figures of each workload on the ``inins`` tree at ``src``.

    Returns
    -------
    dict
        Per workload name: ``cold``, the child's figures on an empty cache
        (``kernels``: rows of name, signature, exclusive CPU s, inclusive CPU s),
        and ``warm``, the same command again on the cache the cold run filled.
        With ``warm_up``, also ``warm-up``: the modules' ``warm_up()`` on an empty
        cache, and ``after_warm_up``: each command on the cache it filled (what a
        user sees after an install step that warms up).
    """
    figures = {}
    for workload in WORKLOADS:
        with tempfile.TemporaryDirectory() as tmp:
            cache = Path(tmp) / "numba-cache"
            cache.mkdir()
            cold = _child(src, cache, Path(tmp) / "cold", workload)
            warm = _child(src, cache, Path(tmp) / "warm", workload)
        figures[workload[0]] = {"cold": cold, "warm": warm}
    if warm_up:
        with tempfile.TemporaryDirectory() as tmp:
            cache = Path(tmp) / "numba-cache"
            cache.mkdir()
            figures["warm-up"] = {"cold": _child(src, cache, tmp, ("warm-up", *WARM_UP))}
            for workload in WORKLOADS:
                after = _child(src, cache, Path(tmp) / "after", workload)
                figures[workload[0]]["after_warm_up"] = after
    return figures


def per_kernel(kernels):
    """``{name: (exclusive CPU s, specialisations)}`` summed over signatures."""
    out = {}
    for name, _, exclusive, _ in kernels:
        seconds, count = out.get(name, (0.0, 0))
        out[name] = (seconds + exclusive, count + 1)
    return out


def _summary(figures):
    result = {}
    for name, runs in figures.items():
        if name == "warm-up":
            cold = runs["cold"]
            result["warm_up_compile_cpu_s"] = sum(r[2] for r in cold["kernels"])
            result["warm_up_wall_s"] = cold["process_wall_s"]
            continue
        cold, warm = runs["cold"], runs["warm"]
        kernels = per_kernel(cold["kernels"])
        result[f"{name}_compile_cpu_s"] = sum(s for s, _ in kernels.values())
        result[f"{name}_compiled_functions"] = len(kernels)
        result[f"{name}_specialisations"] = sum(c for _, c in kernels.values())
        result[f"{name}_first_run_wall_s"] = cold["process_wall_s"]
        result[f"{name}_first_run_cpu_s"] = cold["cpu_s"]
        result[f"{name}_warm_run_wall_s"] = warm["process_wall_s"]
        result[f"{name}_warm_run_cpu_s"] = warm["cpu_s"]
        if "after_warm_up" in runs:
            after = runs["after_warm_up"]
            result[f"{name}_after_warm_up_compiled"] = len(after["kernels"])
            result[f"{name}_after_warm_up_wall_s"] = after["process_wall_s"]
    return result


def warmup_times(src=ROOT):
    """``inins warmup COMMAND`` of each command on an empty cache, one process: the
    compile time a command's first runs pay (``inins.commands.warmup.COMPILE_S``)."""
    from inins.commands.warmup import RUNS

    figures = {}
    for command in RUNS:
        with tempfile.TemporaryDirectory() as tmp:
            cache = Path(tmp) / "numba-cache"
            cache.mkdir()
            done = _child(src, cache, tmp, ("warmup", command, "--jobs", "1"))
        figures[f"warmup_{command}_wall_s"] = done["process_wall_s"]
        figures[f"warmup_{command}_cpu_s"] = done["cpu_s"]
    return figures


def run():
    """Cold-cache compile figures of the working tree (flat dict, unit in each key)."""
    return {**_summary(measure()), **warmup_times()}


def _export(rev, dest):
    """Write the ``inins`` package of git revision ``rev`` under ``dest``."""
    archive = subprocess.run(
        ["git", "archive", rev, "inins", "configs", "data"],
        cwd=ROOT,
        check=True,
        capture_output=True,
    ).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)


def _print_side_by_side(columns, workload="calibrate-bias"):
    tables = {
        label: per_kernel(figs[workload]["cold"]["kernels"]) for label, figs in columns.items()
    }
    names = sorted(
        {n for table in tables.values() for n in table},
        key=lambda n: -max(table.get(n, (0.0, 0))[0] for table in tables.values()),
    )
    labels = list(columns)
    print(f"{workload}, cold cache: compile CPU s per function (specialisations)")
    print(f"{'function':60s}" + "".join(f"{label:>18s}" for label in labels))
    for name in names:
        cells = []
        for label in labels:
            s, c = tables[label].get(name, (0.0, 0))
            cells.append(f"{s:12.3f} ({c:2d})" if c else f"{'-':>18s}")
        print(f"{name[-60:]:60s}" + "".join(cells))
    print()
    summaries = {label: _summary(figs) for label, figs in columns.items()}
    for key in summaries[labels[-1]]:
        print(
            f"{key:60s}" + "".join(f"{summaries[lb].get(key, float('nan')):18.3f}" for lb in labels)
        )


def main():
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_compile")
    parser.add_argument("--against", metavar="REV", help="also measure git revision REV")
    parser.add_argument("--json", type=Path, help="also write the raw figures here")
    args = parser.parse_args()
    columns = {}
    with tempfile.TemporaryDirectory() as tmp:
        if args.against:
            _export(args.against, tmp)
            columns[args.against] = measure(Path(tmp), warm_up=False)
        columns["working tree"] = measure(ROOT)
    _print_side_by_side(columns)
    if args.json:
        args.json.write_text(json.dumps(columns, indent=2))


if __name__ == "__main__":
    main()
