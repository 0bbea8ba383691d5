"""Fixed cost of the default commands, as whole processes, beside ``import numpy``.

``python -m benchmarks.bench_fixed_cost [--runs N] [--first-run]`` prints JSON.

- ``<command>_s``: median wall time of ``inins <command> -o DIR`` (the shipped
  default scenario), interpreter start-up, imports, kernel loading and writing
  included, with the kernel library as ``make kernels`` leaves it;
  ``<command>_over_import_numpy``: the median, pair by pair, of that time over
  ``python -c "import numpy"`` run just before it (pairs keep the ratio
  meaningful on a shared machine whose speed drifts).
- ``<command>_through_numba_s``: the same run with an empty kernel-library folder
  (numba's on-disk cache only): what the kernel library saves a short run.
- ``<command>_cpu_s``, ``<command>_cpu_over_import_numpy``: the same runs' CPU time
  (user + system, the process and the threads it waited for), which other
  processes on a shared machine disturb less than the wall time;
  ``<command>_loads_<module>``: 1 if a default run has imported numba, scipy, typer
  or rich by its end, else 0 (numba stays unloaded: the kernel library's job).
- ``--first-run``: ``first_<command>_s``, the first run after a plain
  ``pip install .`` of this checkout into a new virtual environment (its build
  hook compiles the kernels into the wheel, for this machine; ``pip_install_s``),
  each default command run once from there, outside the source tree (about two
  minutes, most of it the install); ``first_<command>_compiled`` 1 if that run
  compiled a kernel; ``first_<command>_cold_s``, the first
  run with nothing compiled (an empty numba cache and no kernel library: an
  editable install before ``make kernels``, or a wheel built with
  ``ININS_BUILD_KERNELS=0``), when every kernel compiles and the run says so.

Targets (issue: fixed cost): simulate-table <= 0.4 s, observability <= 0.6 s,
run-ekf <= 1.5 s; a first run <= 5 s.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = ("simulate-table", "observability", "run-ekf")


def _timed(args, env):
    """``(wall, cpu)`` seconds of one process (cpu: user + system, from ``wait4``)."""
    start = time.perf_counter()
    child = subprocess.Popen(
        args, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    stderr = child.stderr.read()
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    child.stderr.close()
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode not in (0, 1):
        raise RuntimeError(f"{' '.join(map(str, args))}: exit {child.returncode}\n{stderr}")
    return wall, usage.ru_utime + usage.ru_stime


def _wall(args, env):
    return _timed(args, env)[0]


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


def _command(name, outdir):
    return [sys.executable, "-m", "inins", name, "-o", str(Path(outdir) / name)]


def run(runs: int = 5, first_run: bool = False) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    figures = {"load_average_1min_before": os.getloadavg()[0]}
    numpy = [sys.executable, "-c", "import numpy"]
    with tempfile.TemporaryDirectory() as outdir:
        numba_env = {**env, "ININS_KERNEL_DIR": str(Path(outdir) / "no-library")}
        base, base_cpu = [], []
        for name in COMMANDS:
            args = _command(name, outdir)
            _wall(args, env)  # bytecode written, caches read once
            library, numba, ratios, cpu, cpu_ratios = [], [], [], [], []
            for _ in range(runs):  # alternate: every variant sees the same load
                wall, seconds = _timed(numpy, env)
                base.append(wall)
                base_cpu.append(seconds)
                wall, seconds = _timed(args, env)
                library.append(wall)
                cpu.append(seconds)
                ratios.append(library[-1] / base[-1])
                cpu_ratios.append(cpu[-1] / base_cpu[-1])
                numba.append(_wall(args, numba_env))
            key = name.replace("-", "_")
            figures[f"{key}_s"] = statistics.median(library)
            figures[f"{key}_over_import_numpy"] = statistics.median(ratios)
            figures[f"{key}_cpu_s"] = statistics.median(cpu)
            figures[f"{key}_cpu_over_import_numpy"] = statistics.median(cpu_ratios)
            figures[f"{key}_through_numba_s"] = statistics.median(numba)
            loaded = _loads(name, outdir, env).split(",")
            for module in ("numba", "scipy", "typer", "rich"):
                figures[f"{key}_loads_{module}"] = float(module in loaded)
        figures["import_numpy_s"] = statistics.median(base)
        figures["import_numpy_cpu_s"] = statistics.median(base_cpu)
        if first_run:
            figures.update(_first_runs(Path(outdir), env))
    figures["load_average_1min_after"] = os.getloadavg()[0]
    return figures


def _first_runs(outdir, env):
    """``first_<command>_s`` after ``pip install .`` into a new virtual environment,
    ``first_<command>_cold_s`` with nothing compiled (module docstring)."""
    figures = {}
    clean = {k: v for k, v in env.items() if k not in ("NUMBA_CACHE_DIR", "ININS_KERNEL_DIR")}
    venv, away = outdir / "venv", outdir / "elsewhere"
    away.mkdir()
    base = getattr(sys, "_base_executable", sys.executable)  # not this environment's
    subprocess.run([base, "-m", "venv", str(venv)], check=True, capture_output=True)
    python = venv / "bin" / "python"
    install = [str(python), "-m", "pip", "--disable-pip-version-check", "-q", "install", "."]
    start = time.perf_counter()
    subprocess.run(install, cwd=ROOT, env=clean, check=True, capture_output=True)
    figures["pip_install_s"] = time.perf_counter() - start
    for name in COMMANDS:
        key = name.replace("-", "_")
        args = [str(python), "-m", "inins", name, "-o", str(away / name)]
        start = time.perf_counter()
        done = subprocess.run(args, cwd=away, env=clean, check=True, capture_output=True)
        figures[f"first_{key}_s"] = time.perf_counter() - start
        figures[f"first_{key}_compiled"] = float(b"compiling numerical kernels" in done.stderr)
    for name in COMMANDS:
        fresh = outdir / f"fresh-{name}"
        cold = {
            **env,
            "NUMBA_CACHE_DIR": str(fresh / "numba"),
            "ININS_KERNEL_DIR": str(fresh / "library"),
        }
        key = name.replace("-", "_")
        figures[f"first_{key}_cold_s"] = _wall(_command(name, outdir), cold)
    return figures


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_fixed_cost")
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--first-run", action="store_true", help="also the cold first runs")
    args = parser.parse_args(argv)
    json.dump(run(args.runs, args.first_run), sys.stdout, indent=2)
    print()


if __name__ == "__main__":
    main()
