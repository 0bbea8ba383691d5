"""Fixed cost of the default commands, as whole processes, beside ``import numpy, numba``.

``python -m benchmarks.bench_fixed_cost [--runs N] [--first-run]`` prints JSON.

- ``<command>_s``, ``<command>_cpu_s``: median wall and CPU time (user + system) of
  ``inins <command> -o DIR`` on its shipped default scenario: interpreter start-up,
  imports, loading the cached kernels, the run and its writing;
  ``<command>_over_import``, ``<command>_cpu_over_import``: the median, pair by pair,
  of those over ``python -c "import numpy, numba"`` run just before (pairs keep the
  ratio meaningful on a shared machine whose speed drifts);
  with ``--against REV`` (the full ``make bench``: :data:`BEFORE`), the same figures of
  git revision REV measured pair by pair with this tree (``<command>_before_cpu_s``,
  ...), and ``<command>_cpu_rise_s``, the difference of the CPU medians.
- ``<command>_loads_<module>``: 1 if a default run has imported numba, scipy, typer or
  rich by its end, else 0.
- ``--first-run``: ``pip_install_s`` (``pip install .`` of this checkout into a new
  virtual environment: a pure-Python wheel, ``wheel_pure`` 1), then each default
  command's first run there, outside the source tree, on an empty kernel cache:
  ``first_<command>_s`` and ``first_<command>_longest_silence_s`` (the longest time
  without a line on the terminal: a compile says what it does at least every 5 s).
"""

import argparse
import itertools
import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = (
    "simulate-table",
    "calibrate-bias",
    "align-ett",
    "import-log",
    "import-flight",
    "run-ekf",
    "observability",
    "noise",
    "calibrate-imu",
)
BASE = [sys.executable, "-c", "import numpy, numba"]
BEFORE = "1b02ed5"
"""Main before numba's public cache replaced the AOT kernel library (issue 29): the full
``make bench`` measures it pair by pair with this tree (:func:`against`)."""


def _timed(args, env, cwd=ROOT):
    """``(wall, cpu)`` seconds of one process (cpu: user + system, from ``wait4``)."""
    start = time.perf_counter()
    child = subprocess.Popen(
        args, cwd=cwd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    stderr = child.stderr.read()
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    child.stderr.close()
    code = os.waitstatus_to_exitcode(status)
    if code not in (0, 1):
        raise RuntimeError(f"{' '.join(map(str, args))}: exit {code}\n{stderr.decode()}")
    return wall, usage.ru_utime + usage.ru_stime


HEAVY = ("numba", "llvmlite", "scipy", "typer", "rich", "click", "matplotlib")
_LOADS = (
    "import runpy, sys\n"
    "sys.argv = ['inins', *sys.argv[1:]]\n"
    "try:\n    runpy.run_module('inins', run_name='__main__')\n"
    "except SystemExit:\n    pass\n"
    f"print(','.join(m for m in {HEAVY!r} if m in sys.modules), file=sys.stderr)\n"
)


def _loads(name, outdir, env):
    """The heavy modules (:data:`HEAVY`) a default run of ``name`` has imported at its end."""
    args = [sys.executable, "-c", _LOADS, name, "-o", str(Path(outdir) / f"loads-{name}")]
    done = subprocess.run(args, capture_output=True, text=True, cwd=ROOT, env=env, check=False)
    return done.stderr.strip().splitlines()[-1] if done.stderr.strip() else ""


def _command(name, outdir, python=sys.executable):
    return [python, "-m", "inins", name, "-o", str(Path(outdir) / name)]


def measure(commands, runs, env, outdir, python=sys.executable, cwd=ROOT):
    """``{command: (wall, cpu, wall ratio, cpu ratio)}``, medians over ``runs`` pairs of
    (``import numpy, numba``, the default run)."""
    figures = {}
    for name in commands:
        args = _command(name, outdir, python)
        _timed(args, env, cwd)  # bytecode written, kernels loaded once
        rows = []
        for _ in range(runs):
            base_wall, base_cpu = _timed(BASE, env)
            wall, cpu = _timed(args, env, cwd)
            rows.append((wall, cpu, wall / base_wall, cpu / base_cpu))
        figures[name] = tuple(statistics.median(r[i] for r in rows) for i in range(4))
    return figures


def run(runs: int = 5, first_run: bool = False, before: str | None = None) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    figures = {"load_average_1min_before": os.getloadavg()[0]}
    with tempfile.TemporaryDirectory() as outdir:
        for name, (wall, cpu, wall_x, cpu_x) in measure(COMMANDS, runs, env, outdir).items():
            key = name.replace("-", "_")
            figures[f"{key}_s"] = wall
            figures[f"{key}_cpu_s"] = cpu
            figures[f"{key}_over_import"] = wall_x
            figures[f"{key}_cpu_over_import"] = cpu_x
            loaded = _loads(name, outdir, env).split(",")
            for module in ("numba", "scipy", "typer", "rich"):
                figures[f"{key}_loads_{module}"] = float(module in loaded)
        base = [_timed(BASE, env) for _ in range(runs)]
        figures["import_numpy_numba_s"] = statistics.median(b[0] for b in base)
        figures["import_numpy_numba_cpu_s"] = statistics.median(b[1] for b in base)
        if first_run:
            figures.update(_first_runs(Path(outdir), env))
    if before:
        try:
            paired_runs = against(before, runs)
        except subprocess.CalledProcessError:  # a shallow clone: the revision is not here
            print(f"bench_fixed_cost: revision {before} not available", file=sys.stderr)
            paired_runs = {}
        for name, paired in paired_runs.items():
            key = name.replace("-", "_")
            figures.update({f"{key}_{what}": value for what, value in paired.items()})
            figures[f"{key}_cpu_rise_s"] = paired["after_cpu_s"] - paired["before_cpu_s"]
    figures["load_average_1min_after"] = os.getloadavg()[0]
    return figures


def _first_runs(outdir, env):
    """``pip install .`` into a new virtual environment, then each default command's first
    run there on an empty kernel cache (module docstring)."""
    figures = {}
    clean = {k: v for k, v in env.items() if k != "NUMBA_CACHE_DIR"}
    venv, away = outdir / "venv", outdir / "elsewhere"
    away.mkdir()
    base = getattr(sys, "_base_executable", sys.executable)  # not this environment's
    subprocess.run([base, "-m", "venv", str(venv)], check=True, capture_output=True)
    python = venv / "bin" / "python"
    wheels = outdir / "wheels"
    start = time.perf_counter()
    subprocess.run(
        [str(python), "-m", "pip", "-q", "wheel", "--no-deps", "-w", str(wheels), "."],
        cwd=ROOT,
        env=clean,
        check=True,
        capture_output=True,
    )
    (wheel,) = wheels.glob("inins-*.whl")
    figures["wheel_pure"] = float(wheel.name.endswith("-py3-none-any.whl"))
    subprocess.run(
        [str(python), "-m", "pip", "-q", "install", str(wheel)],
        cwd=away,
        env=clean,
        check=True,
        capture_output=True,
    )
    figures["pip_install_s"] = time.perf_counter() - start
    cache = {**clean, "NUMBA_CACHE_DIR": str(outdir / "first-cache")}
    for name in COMMANDS:
        key = name.replace("-", "_")
        wall, silence = _first_run(
            [str(python), "-m", "inins", name, "-o", str(away / name)], cache, away
        )
        figures[f"first_{key}_s"] = wall
        figures[f"first_{key}_longest_silence_s"] = silence
    return figures


def _first_run(args, env, cwd):
    """Wall time of one run and the longest time between two lines it printed."""
    start = time.perf_counter()
    child = subprocess.Popen(
        args, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    stamps = [start]

    def read():
        for _ in child.stdout:
            stamps.append(time.perf_counter())

    reader = threading.Thread(target=read)
    reader.start()
    child.wait()
    reader.join()
    end = time.perf_counter()
    stamps.append(end)
    return end - start, max(b - a for a, b in itertools.pairwise(stamps))


def against(revision, runs):
    """This tree and git ``revision`` (its own kernels warmed up as its Makefile did),
    pair by pair: ``{command: {"before": cpu, "after": cpu}}``."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    with tempfile.TemporaryDirectory() as work:
        old = Path(work) / "tree"
        old.mkdir()
        archive = subprocess.run(
            ["git", "archive", revision], cwd=ROOT, check=True, capture_output=True
        ).stdout
        subprocess.run(["tar", "-x", "-C", str(old)], input=archive, check=True)
        old_env = {**env, "PYTHONPATH": str(old), "NUMBA_CACHE_DIR": str(Path(work) / "cache")}
        subprocess.run(
            [sys.executable, "-m", "inins.commands.warmup"], cwd=old, env=old_env, check=True
        )
        figures = {}
        for name in COMMANDS:
            pairs = [  # alternate, so that both see the same machine load
                (
                    measure([name], 1, old_env, work, cwd=old)[name],
                    measure([name], 1, env, work)[name],
                )
                for _ in range(runs)
            ]
            figures[name] = {
                f"{when}_{what}": statistics.median(p[i][k] for p in pairs)
                for i, when in enumerate(("before", "after"))
                for k, what in enumerate(("s", "cpu_s", "over_import", "cpu_over_import"))
            }
            print(name, figures[name], file=sys.stderr, flush=True)
    return figures


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_fixed_cost")
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--first-run", action="store_true", help="also the first runs")
    parser.add_argument("--against", metavar="REV", help="pair by pair with git revision REV")
    args = parser.parse_args(argv)
    json.dump(run(args.runs, args.first_run, args.against), sys.stdout, indent=2)
    print()


if __name__ == "__main__":
    main()
