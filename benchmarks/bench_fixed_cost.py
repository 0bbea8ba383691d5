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
- ``--first-run``: ``first_<command>_s``, the first run after a plain install
  (an empty numba cache and no kernel library: every kernel compiles), one run
  each (slow: up to a minute).

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


def _wall(args, env):
    start = time.perf_counter()
    done = subprocess.run(args, capture_output=True, cwd=ROOT, env=env, check=False)
    wall = time.perf_counter() - start
    if done.returncode not in (0, 1):
        raise RuntimeError(f"{' '.join(map(str, args))}: exit {done.returncode}\n{done.stderr}")
    return wall


def _command(name, outdir):
    return [sys.executable, "-m", "inins", name, "-o", str(Path(outdir) / name)]


def run(runs: int = 5, first_run: bool = False) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    figures = {"load_average_1min_before": os.getloadavg()[0]}
    numpy = [sys.executable, "-c", "import numpy"]
    with tempfile.TemporaryDirectory() as outdir:
        numba_env = {**env, "ININS_KERNEL_DIR": str(Path(outdir) / "no-library")}
        base = []
        for name in COMMANDS:
            args = _command(name, outdir)
            _wall(args, env)  # bytecode written, caches read once
            library, numba, ratios = [], [], []
            for _ in range(runs):  # alternate: every variant sees the same load
                base.append(_wall(numpy, env))
                library.append(_wall(args, env))
                ratios.append(library[-1] / base[-1])
                numba.append(_wall(args, numba_env))
            key = name.replace("-", "_")
            figures[f"{key}_s"] = statistics.median(library)
            figures[f"{key}_over_import_numpy"] = statistics.median(ratios)
            figures[f"{key}_through_numba_s"] = statistics.median(numba)
        figures["import_numpy_s"] = statistics.median(base)
        if first_run:
            for name in COMMANDS:
                fresh = Path(outdir) / f"fresh-{name}"
                cold = {
                    **env,
                    "NUMBA_CACHE_DIR": str(fresh / "numba"),
                    "ININS_KERNEL_DIR": str(fresh / "library"),
                }
                key = name.replace("-", "_")
                figures[f"first_{key}_s"] = _wall(_command(name, outdir), cold)
    figures["load_average_1min_after"] = os.getloadavg()[0]
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
