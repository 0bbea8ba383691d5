"""``make bench``: throughput, wall time and peak memory of the hot paths and commands.

Each benchmark runs in its own child process so that its peak RSS is its own.
Figures are printed as one table; ``--json FILE`` also writes them. ``--quick``
skips the 24 h runs (about a minute on a slow machine). Command figures are whole
processes: interpreter start-up, imports and loading the cached JIT code included.
"""

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).parent
MODULES = ("bench_strapdown", "bench_imu", "bench_table", "bench_sweep")


def _module(name):
    code = f"import json, benchmarks.{name} as m; print(json.dumps(m.run()))"
    out = subprocess.run(
        [sys.executable, "-c", code], check=True, capture_output=True, text=True, cwd=HERE.parent
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def _command(*args):
    """Run ``inins ARGS`` in a child; its wall time, peak RSS and exit code."""
    out = subprocess.run(
        [sys.executable, "-m", "benchmarks._measure", *args],
        capture_output=True,
        text=True,
        cwd=HERE.parent,
    )
    figures = json.loads(out.stderr.strip().splitlines()[-1])
    if figures["exit"] != 0:
        raise RuntimeError(f"inins {' '.join(args)} failed:\n{out.stderr}")
    return figures


def _help_startup():
    times = []
    for _ in range(7):
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "inins", "--help"], check=True, capture_output=True)
        times.append(time.perf_counter() - start)
    return {"median_s": statistics.median(times), "max_s": max(times)}


def _table_commands(outdir, long):
    """simulate-table, then calibrate-bias on the file it wrote (2 h at 1 kHz; 24 h)."""
    scenarios = HERE / "scenarios"
    figures = {}
    runs = {"2h_1khz": []}
    if long:  # the same sequence stretched to 24 h: 86.4 M samples
        runs["24h_1khz"] = [
            "--set",
            "motion.0.duration_s=43170",
            "--set",
            "motion.2.duration_s=43170",
            "--set",
            "mount.rotations.0.duration_s=86400",
        ]
    for name, extra in runs.items():
        out = Path(outdir) / name
        args = ("simulate-table", str(scenarios / "table1-2h-1khz.yaml"), "-o", str(out), *extra)
        figures[f"simulate_table_{name}"] = _command(*args)
        shutil.copy(scenarios / "calibrate-2h-1khz.yaml", out / "calibrate.yaml")
        figures[f"calibrate_bias_{name}"] = _command(
            "calibrate-bias", str(out / "calibrate.yaml"), "-o", str(out / "calibrate")
        )
    return figures


def _align_ett(outdir):
    """align-ett on a 10-minute two-position record."""
    out = Path(outdir) / "ett"
    _command("simulate-table", str(HERE / "scenarios" / "ett-10min.yaml"), "-o", str(out))
    shutil.copy(HERE / "scenarios" / "align-ett-10min.yaml", out / "align.yaml")
    return _command("align-ett", str(out / "align.yaml"), "-o", str(out / "a"))


def _import_log(outdir):
    """import-log of the RLG excerpt (PSINS text, 40,000 rows)."""
    figures = _command("import-log", "-o", str(Path(outdir) / "import"))
    figures["rows_per_s_warm"] = 40_000 / figures["warm_s"]
    return figures


def main():
    parser = argparse.ArgumentParser(prog="python -m benchmarks")
    parser.add_argument("--quick", action="store_true", help="skip the 24 h runs")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    figures = {name: _module(name) for name in MODULES}
    figures["inins_help"] = _help_startup()
    with tempfile.TemporaryDirectory() as outdir:
        figures["commands"] = _table_commands(outdir, not args.quick)
        figures["commands"]["align_ett_10min"] = _align_ett(outdir)
        figures["commands"]["import_log_rlg_excerpt"] = _import_log(outdir)
    for group, values in figures.items():
        print(group)
        for key, value in _flat(values):
            print(f"  {key:32s} {value:12.6g}")
    if args.json:
        args.json.write_text(json.dumps(figures, indent=2))


def _flat(values, prefix=""):
    for key, value in values.items():
        if isinstance(value, dict):
            yield from _flat(value, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}", value


if __name__ == "__main__":
    main()
