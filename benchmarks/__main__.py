"""``make bench``: throughput, wall time and peak memory of the hot paths and commands.

Each benchmark runs in its own child process so that its peak RSS is its own.
Figures are printed as one table, then every figure that has a target (the issues'
speed and memory requirements, :data:`TARGETS`) against it, so a regression shows at
once; ``--json FILE`` also writes them. ``--quick`` (``make bench-quick``) skips the
24 h runs and the cold-cache compile measurement (about a minute). Command figures
are whole processes: interpreter start-up, imports and loading the cached JIT code
included. Each module's child loads numba first (:mod:`inins.core.jit`), so that a
kernel's throughput is measured without numba's start-up.
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
ROOT = HERE.parent
SLOW_MODULES = ("bench_compile",)
FIXED_COST = "bench_fixed_cost"
"""Whole-process figures of the default commands (``--quick``: 3 runs, no first run)."""
"""Left out by ``--quick``."""
QUICK_AWARE = (
    "bench_ekf",
    "bench_sweep",
    "bench_imu",
    "bench_noise",
    "bench_ekf_post",
    "bench_gnss",
    "bench_whole",
    "bench_ekf_length",
)
"""Modules whose ``run(quick=True)`` drops their long parts (the 4-h EKF stream, the
sweep throughput runs, the chunked sensor-error pass; run-ekf over 5 min / 30 min / 2 h
instead of 10 min / 1 h / 4 h / 24 h)."""
TARGETS = (  # (figure path, relation, target, what)
    ("bench_strapdown.free_hour_200hz_msamples_per_s", ">=", 12.0, "strapdown free, M samples/s"),
    ("bench_strapdown.fixed_hour_200hz_msamples_per_s", ">=", 20.0, "strapdown fixed, M samples/s"),
    ("bench_imu.samples_per_s", ">=", 5e6, "sensor error model, samples/s"),
    ("bench_gnss.states_32sat_1hz_24h_s", "<", 1.0, "32 satellites 24 h at 1 Hz, s"),
    ("bench_gnss.spp_abpo_day_s", "<", 0.5, "SPP of the ABPO day, s"),
    ("bench_gnss.read_obs_abpo_s", "<", 0.5, "read the ABPO observations, s"),
    ("bench_gnss.states_all_systems_1hz_24h_s", "<", 3.0, "4 systems 24 h at 1 Hz, s"),
    ("bench_gnss.read_obs_mixed_day_s", "<", 0.5, "read 24 h 4-system RINEX 3, s"),
    ("bench_gnss.spp_mixed_day_s", "<", 1.0, "SPP of a 4-system day, s"),
    ("bench_observability.som_26x100_s", "<", 0.2, "26-state SOM over 100 segments, s"),
    ("bench_observability.covariance_1h_1hz_s", "<", 1.0, "covariance 1 h at 1 Hz, s"),
    ("bench_ekf.hour_ekf2_fb_s", "<", 2.0, "EKF2-FB one hour, s"),
    ("bench_ekf.stream_4h_peak_rss_mb", "<", 1024.0, "EKF 4-h flight peak RSS, MB"),
    ("inins_help.median_s", "<", 0.5, "inins --help, s"),
    ("commands.calibrate_bias_2h_1khz.warm_s", "<", 2.0, "calibrate-bias 2 h at 1 kHz warm, s"),
    ("commands.calibrate_bias_24h_1khz.peak_rss_mb", "<", 1024.0, "calibrate-bias 24 h RSS, MB"),
    ("commands.simulate_table_24h_1khz.peak_rss_mb", "<", 1024.0, "simulate-table 24 h RSS, MB"),
    ("commands.align_ett_10min.warm_s", "<", 0.5, "align-ett 10-min record warm, s"),
    ("bench_compile.calibrate-bias_compile_cpu_s", "<", 5.0, "first calibrate-bias compile, CPU s"),
    ("calibrate_memory.rss_4h_over_10min", "<", 1.10, "calibrate-bias RSS 4-h / 10-min holds"),
    (
        "commands.simulate_table_fixed_cost.one_minute_wall_s",
        "<",
        0.7,
        "simulate-table 1-min run, s",
    ),
    ("bench_sweep.overhead.overhead_ms", "<", 20.0, "sweep overhead per point, ms"),
    ("bench_sweep.throughput.speedup_2_workers", ">=", 1.8, "sweep 2 workers / 1 worker"),
    ("bench_sweep.throughput.dask_over_local", ">=", 0.8, "sweep Dask loopback / local"),
    ("bench_strapdown.free_over_pyins_kernel", ">=", 5.0, "strapdown / pyins' numba kernel"),
    ("bench_sweep.overhead.local_start_s", "<", 0.5, "sweep start-up (2 points), s"),
    *(
        (f"bench_fixed_cost.{c}_cpu_rise_s", "<", 0.5, f"default {c} CPU over the AOT library, s")
        for c in (
            "simulate_table",
            "calibrate_bias",
            "align_ett",
            "import_log",
            "import_flight",
            "run_ekf",
            "observability",
            "noise",
            "calibrate_imu",
        )
    ),
    *(
        (f"bench_fixed_cost.first_{c}_longest_silence_s", "<", 10.0, f"first {c}: silent, s")
        for c in ("simulate_table", "calibrate_bias", "run_ekf", "observability")
    ),
    ("bench_fixed_cost.pip_install_s", "<", 90.0, "pip install . (wheel of this tree), s"),
    ("bench_fixed_cost.wheel_pure", ">=", 1.0, "the wheel is pure Python (1 = yes)"),
    ("bench_ekf.hour_filter_alone_s", "<", 0.15, "EKF2-FB filter alone one hour, s"),
    ("bench_ekf.hour_truth_scoring_s", "<", 0.1, "EKF truth scoring one hour, s"),
    ("bench_ekf.simulation_4h_over_1h_cpu", "<=", 4.2, "run-ekf simulation 4 h / 1 h"),
    ("bench_ekf.process_run_ekf_1h_warm_s", "<", 1.5, "run-ekf 1-h flight whole process, s"),
    ("bench_noise.noise_24h_extrapolated_s", "<", 10.0, "noise 24 h 1 kHz 6 sensors, s (extrap.)"),
    ("bench_noise.noise_peak_rss_mb", "<", 1024.0, "noise peak RSS, MB"),
    (
        "bench_noise.full_overlap_speedup_min",
        ">=",
        1.0,
        "full-overlap ADEV over allantools oadev, 1e6-1e8",
    ),
    (
        "bench_noise.speedup_over_allantools",
        ">=",
        5.0,
        "noise (16 starts per tau) / allantools oadev (full)",
    ),
    ("bench_noise.noise_cpu_24h_extrapolated_s", "<", 10.0, "noise 24 h CPU, s (extrap.)"),
    ("bench_ekf_post.hour_loose_total_s", "<", 0.5, "loose + RTS one hour, s"),
    ("bench_ekf_post.stream_4h_peak_rss_mb", "<", 1024.0, "loose + RTS 4-h peak RSS, MB"),
    ("bench_ekf_post.hour_tight_total_s", "<", 2.0, "tight EKF2-FB + RTS one hour, s"),
    ("commands.calibrate_imu_1h_1khz.warm_s", "<", 2.0, "calibrate-imu 24-pos + rates 1 h, s"),
    ("commands.calibrate_imu_xsens.warm_s", "<", 1.0, "calibrate-imu table-free Xsens, s"),
    ("bench_whole.spp_cpu_over_rnx2rtkp", "<=", 1.0, "ABPO SPP process CPU / rnx2rtkp's"),
    ("bench_whole.run_ekf_1h_cpu_over_floor", "<=", 1.5, "run-ekf 1-h process CPU / floor"),
    ("bench_gnss.read_obs_24h_1hz_values_per_s", ">=", 1e6, "24-h 1-Hz RINEX 3 read, values/s"),
    (
        "bench_ekf_length.rss_longest_over_shortest",
        "<=",
        1.5,
        "run-ekf RSS 24h / 10min (quick 2h / 5min)",
    ),
    ("bench_ekf_length.cpu_per_hour_spread", "<=", 1.10, "run-ekf CPU per flight hour max/min"),
)
MODULES = (
    "bench_strapdown",
    "bench_imu",
    "bench_table",
    "bench_gnss",
    "bench_observability",
    "bench_ekf",
    "bench_sweep",
    "bench_noise",
    "bench_ekf_post",
    "bench_whole",
    "bench_ekf_length",
)


def _module(name, quick=False):
    call = "m.run(quick=True)" if quick and name in QUICK_AWARE else "m.run()"
    code = (
        "import json; from inins.core import jit; jit.activate()\n"
        f"import benchmarks.{name} as m; print(json.dumps({call}))"
    )
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


def _help_startup(runs=7):
    times = []
    for _ in range(runs):
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


def _calibrate_memory(outdir):
    """calibrate-bias peak RSS with a simulate: section at 1 kHz, holds of 10 min, 1 h and
    4 h (issue: flat in record length; long simulations spill to a temporary file)."""
    figures = {}
    case = ROOT / "configs" / "paper000" / "case1-no-disturbance.yaml"
    for label, hold in (("10min", 600), ("1h", 3600), ("4h", 14400)):
        run = _command(
            "calibrate-bias",
            str(case),
            "-o",
            str(Path(outdir) / f"mem{label}"),
            "--set",
            "simulate.imu.sample_rate_hz=1000",
            "--set",
            f"simulate.motion.1.duration_s={hold}",
            "--set",
            f"simulate.motion.3.duration_s={hold}",
        )
        figures[f"hold_{label}_peak_rss_mb"] = run["peak_rss_mb"]
    figures["rss_4h_over_10min"] = (
        figures["hold_4h_peak_rss_mb"] / figures["hold_10min_peak_rss_mb"]
    )
    return figures


def _fixed_cost(outdir, runs=3):
    """Whole-process wall time of simulate-table on a one-minute scenario (median of
    runs): the fixed cost a short run pays (start-up, imports, loading the cached
    kernels). Bytecode is written and used as a normal install does
    (``PYTHONDONTWRITEBYTECODE`` unset; one untimed run first).
    """
    import os

    case = ROOT / "configs" / "simulate-table" / "default.yaml"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}

    def once(k):
        start = time.perf_counter()
        subprocess.run(
            [
                sys.executable,
                "-m",
                "inins",
                "simulate-table",
                str(case),
                "-o",
                str(Path(outdir) / f"fixed{k}"),
                "--set",
                "imu.sample_rate_hz=10",
                "--set",
                "motion=[{kind: hold, duration_s: 60}]",
            ],
            check=True,
            capture_output=True,
            cwd=ROOT,
            env=env,
        )
        return time.perf_counter() - start

    once(-1)
    return {"one_minute_wall_s": statistics.median(once(k) for k in range(runs))}


def _import_log(outdir):
    """import-log of the RLG excerpt (PSINS text, 40,000 rows)."""
    figures = _command("import-log", "-o", str(Path(outdir) / "import"))
    figures["rows_per_s_warm"] = 40_000 / figures["warm_s"]
    return figures


def _calibrate_imu(outdir):
    """calibrate-imu: the discrete method on one hour of 1 kHz (24 positions and rate
    tests, a table-data file written by simulate-table), and the table-free method on
    the Xsens log (51,175 samples)."""
    out = Path(outdir) / "calimu"
    scenarios = HERE / "scenarios"
    _command("simulate-table", str(scenarios / "calimu-24pos-1h-1khz.yaml"), "-o", str(out))
    shutil.copy(scenarios / "calibrate-imu-1h.yaml", out / "calibrate.yaml")
    xsens = ROOT / "configs" / "calibrate-imu" / "xsens-real.yaml"
    return {
        "calibrate_imu_1h_1khz": _command(
            "calibrate-imu", str(out / "calibrate.yaml"), "-o", str(out / "c")
        ),
        "calibrate_imu_xsens": _command("calibrate-imu", str(xsens), "-o", str(out / "x")),
    }


def main():
    parser = argparse.ArgumentParser(prog="python -m benchmarks")
    parser.add_argument("--quick", action="store_true", help="skip the 24 h runs")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    modules = MODULES if args.quick else MODULES + SLOW_MODULES
    figures = {name: _module(name, args.quick) for name in modules}
    from benchmarks import bench_fixed_cost

    figures[FIXED_COST] = bench_fixed_cost.run(
        3 if args.quick else 5, not args.quick, None if args.quick else bench_fixed_cost.BEFORE
    )
    figures["inins_help"] = _help_startup(3 if args.quick else 7)
    with tempfile.TemporaryDirectory() as outdir:
        figures["commands"] = _table_commands(outdir, not args.quick)
        figures["commands"]["align_ett_10min"] = _align_ett(outdir)
        figures["commands"]["import_log_rlg_excerpt"] = _import_log(outdir)
        figures["commands"].update(_calibrate_imu(outdir))
        figures["commands"]["simulate_table_fixed_cost"] = _fixed_cost(
            outdir, 3 if args.quick else 5
        )
        if not args.quick:
            figures["calibrate_memory"] = _calibrate_memory(outdir)
    for group, values in figures.items():
        print(group)
        for key, value in _flat(values):
            print(f"  {key:32s} {value:12.6g}")
    print()
    print(targets_table(figures))
    if args.json:
        args.json.write_text(json.dumps(figures, indent=2))


def targets_table(figures):
    """Every figure that has a target: measured, target, ok (n/a where not run)."""
    flat = dict(_flat(figures))
    rows = [f"{'target':44s} {'measured':>12s} {'':2s} {'target':>10s}  ok"]
    for path, relation, target, what in TARGETS:
        value = flat.get(path)
        if value is None:
            rows.append(f"{what:44s} {'n/a':>12s} {relation:2s} {target:10.4g}  -")
            continue
        ok = {">=": value >= target, "<=": value <= target}.get(relation, value < target)
        rows.append(
            f"{what:44s} {value:12.4g} {relation:2s} {target:10.4g}  {'yes' if ok else 'NO'}"
        )
    return "\n".join(rows)


def _flat(values, prefix=""):
    for key, value in values.items():
        if isinstance(value, dict):
            yield from _flat(value, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}", value


if __name__ == "__main__":
    main()
