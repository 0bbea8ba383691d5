"""Whole processes beside their peer or their floor (issue 34), alternating, medians.

``python -m benchmarks.bench_whole [--runs N]`` prints JSON. Every figure is a median
over ``N`` (default 5) rounds; a round runs the two processes one after the other, in
alternating order, so that both see the same load on a shared machine; CPU is user +
system of the process and of every process it waited for (``wait4``).

- ``spp_*``: the ABPO day's single-point positioning, ``inins import-flight`` on its
  default scenario (RINEX 2.11 observations and navigation, gzip, GPS P1/P2
  ionosphere-free, Saastamoinen troposphere, 10 deg mask, HDF5 + report + summary
  written) beside RTKLIB's ``rnx2rtkp`` on the same two files with the same settings
  (:data:`RTKLIB_CONF`: single mode, L1+L2, dual-frequency ionosphere, Saastamoinen,
  broadcast ephemerides, GPS, 10 deg, ECEF output). ``rnx2rtkp`` reads no settings but
  those given (``-k``); its gzip input is unpacked by ``gzip`` in a child, counted in
  its CPU. ``spp_cpu_over_rnx2rtkp`` (target <= 1) is the median of the per-round
  ratios. Both solutions are scored against the header position (``*_rms_m``) so that
  the settings are seen to be comparable. Skipped with a note where ``rnx2rtkp`` is
  not installed (Debian: ``apt-get install rtklib``).
- ``run_ekf_1h_*``: ``inins run-ekf benchmarks/scenarios/run-ekf-1h.yaml`` beside its
  floor (:func:`floor`): the same imports, the truth and IMU stream of the hour and the
  filter alone on the hour's epochs, measured in one process (the receiver simulation,
  the scoring against truth and the output files left out);
  ``run_ekf_1h_cpu_over_floor`` (target <= 1.5).
"""

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data"
EKF_1H = ROOT / "benchmarks" / "scenarios" / "run-ekf-1h.yaml"
RTKLIB_CONF = """\
pos1-posmode       =single
pos1-frequency     =l1+2
pos1-elmask        =10
pos1-ionoopt       =dual-freq
pos1-tropopt       =saas
pos1-sateph        =brdc
pos1-navsys        =1
out-solformat      =xyz
"""
"""rnx2rtkp settings comparable to the ABPO scenario (RTKLIB 2.4.3 option names)."""


TREE = ROOT
"""The checkout whose ``inins`` runs (``--tree``: another one, e.g. main before issue 34,
with this file's measurements)."""


def _env():
    """The environment of a user's run: bytecode written and used (as an install does),
    the package of :data:`TREE` first on the path."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = str(TREE)
    return env


def _timed(args, env, cwd):
    """``(wall, cpu)`` seconds of one process (cpu: user + system of it and of the
    processes it waited for, from ``wait4``); its output discarded."""
    start = time.perf_counter()
    child = subprocess.Popen(
        args, cwd=cwd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    stderr = child.stderr.read()
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    child.stderr.close()
    if os.waitstatus_to_exitcode(status) not in (0, 1):
        raise RuntimeError(f"{' '.join(map(str, args))} failed:\n{stderr.decode()}")
    return wall, usage.ru_utime + usage.ru_stime


def _rounds(first, second, runs):
    """Medians of ``runs`` alternating rounds of two commands: wall, CPU, and the
    per-round ratios of the first over the second."""
    env = _env()
    _timed(first, env, TREE), _timed(second, env, TREE)  # untimed: file cache, bytecode
    out = {"a": [], "b": []}
    for k in range(runs):
        pair = ((first, "a"), (second, "b")) if k % 2 == 0 else ((second, "b"), (first, "a"))
        for args, key in pair:
            out[key].append(_timed(args, env, TREE))
    med = {}
    for key, values in out.items():
        med[f"{key}_s"] = statistics.median(w for w, _ in values)
        med[f"{key}_cpu_s"] = statistics.median(c for _, c in values)
    pairs = list(zip(out["a"], out["b"], strict=True))
    med["cpu_ratio"] = statistics.median(a[1] / b[1] for a, b in pairs)
    med["wall_ratio"] = statistics.median(a[0] / b[0] for a, b in pairs)
    return med


def _rms_against_header(pos_file):
    """3-D RMS (m) of an rnx2rtkp ECEF solution against the ABPO header position."""
    import numpy as np

    from inins.io.rinex_obs import read_obs

    ref = read_obs(DATA / "abpo0080.15o.gz").approx_pos_e
    rows = [
        line.split()[2:5]
        for line in Path(pos_file).read_text().splitlines()
        if line and not line.startswith("%")
    ]
    xyz = np.array(rows, float)
    return float(np.sqrt(np.mean(np.sum((xyz - ref) ** 2, axis=1)))), len(xyz)


def spp_vs_rtklib(runs=5):
    """The ABPO day: ``inins import-flight`` beside ``rnx2rtkp`` (see the module)."""
    peer = shutil.which("rnx2rtkp")
    if peer is None:
        return {"spp_note": "skipped: rnx2rtkp not installed (apt-get install rtklib)"}
    with tempfile.TemporaryDirectory() as tmp:
        conf = Path(tmp) / "spp.conf"
        conf.write_text(RTKLIB_CONF)
        obs, nav = DATA / "abpo0080.15o.gz", DATA / "abpo0080.15n.gz"
        ours = [sys.executable, "-m", "inins", "import-flight", "-o", f"{tmp}/inins"]
        theirs = [peer, "-k", str(conf), "-o", f"{tmp}/rtk.pos", str(obs), str(nav)]
        med = _rounds(ours, theirs, runs)
        rms, epochs = _rms_against_header(f"{tmp}/rtk.pos")
        summary = json.loads(Path(f"{tmp}/inins/summary.json").read_text())["results"]
    return {
        "spp_inins_s": med["a_s"],
        "spp_inins_cpu_s": med["a_cpu_s"],
        "spp_rnx2rtkp_s": med["b_s"],
        "spp_rnx2rtkp_cpu_s": med["b_cpu_s"],
        "spp_cpu_over_rnx2rtkp": med["cpu_ratio"],
        "spp_wall_over_rnx2rtkp": med["wall_ratio"],
        "spp_inins_rms_m": summary["err_3d_rms_m"],
        "spp_rnx2rtkp_rms_m": rms,
        "spp_rnx2rtkp_epochs": epochs,
    }


def run_ekf_vs_floor(runs=5):
    """The 1-h flight's whole process beside its floor (see the module)."""
    with tempfile.TemporaryDirectory() as tmp:
        ours = [sys.executable, "-m", "inins", "run-ekf", str(EKF_1H), "-o", f"{tmp}/ekf"]
        floor_cmd = [sys.executable, __file__, "--floor", f"{tmp}/f.json"]
        env = _env()
        _timed(ours, env, TREE), _timed(floor_cmd, env, TREE)
        whole, floors = [], []
        for k in range(runs):
            for which in ("whole", "floor") if k % 2 == 0 else ("floor", "whole"):
                if which == "whole":
                    whole.append(_timed(ours, env, TREE))
                else:
                    _timed(floor_cmd, env, TREE)
                    floors.append(json.loads(Path(f"{tmp}/f.json").read_text()))
    ratio = [w[1] / f["floor_cpu_s"] for w, f in zip(whole, floors, strict=True)]
    out = {
        "run_ekf_1h_s": statistics.median(w for w, _ in whole),
        "run_ekf_1h_cpu_s": statistics.median(c for _, c in whole),
        "run_ekf_1h_cpu_over_floor": statistics.median(ratio),
    }
    for key in floors[0]:
        out[f"run_ekf_1h_{key}"] = statistics.median(f[key] for f in floors)
    return out


def _cpu():
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def floor(path):
    """The floor of ``inins run-ekf`` on :data:`EKF_1H`, measured in this process and
    written to ``path`` as JSON: ``imports_cpu_s`` (interpreter start-up and the imports
    of the command, numba included), ``stream_cpu_s`` (the truth and IMU stream of the
    hour, :func:`inins.ekf.flight.imu_stream` in this thread, its kernels loaded from
    the cache), ``filter_cpu_s`` (:func:`inins.ekf.filter.run_filter` alone over the
    hour's epochs, first call: its kernels loaded), ``floor_cpu_s`` their sum, and the
    wall times of the last two."""
    import inins.cli  # noqa: F401  (the command line's own imports)
    from inins.commands import run_ekf
    from inins.core import jit

    jit.activate()
    imports = _cpu()
    import math

    import numpy as np

    from inins.core.units import ARCSEC
    from inins.ekf import flight as fl
    from inins.ekf.config import EpochInput
    from inins.ekf.filter import run_filter
    from inins.scenario.base import load_scenario

    scenario = load_scenario(run_ekf.SCENARIO_MODEL, EKF_1H, [], None)[0]
    epochs, stream, parts = [], None, {}

    def capture(config, initial, t0, epoch_stream, errors, store=None):
        nonlocal stream
        stream = (config, initial, t0)
        epochs.extend(EpochInput(e.dtheta, e.dv, e.pps_index, e.gnss) for e in epoch_stream)
        raise _Captured

    saved = run_ekf.run_filter
    run_ekf.run_filter = capture
    try:
        run_ekf._simulated(scenario, scenario.seed)
    except _Captured:
        pass
    finally:
        run_ekf.run_filter = saved
    fs = scenario.flight
    dt = 1.0 / fs.imu.sample_rate_hz
    plan = fs.plan()
    truth = fl.Dithered(
        fl.flight_trajectory(plan),
        fl.Dither(fs.dither.amplitude_arcsec * ARCSEC, fs.dither.frequency_hz),
    )
    edges = np.round(np.arange(0, math.floor(plan.duration) + 1) / dt).astype(np.int64)
    rng = np.random.default_rng(0)
    wall, cpu = time.perf_counter(), _cpu()
    for _ in fl.imu_stream(truth, fs.imu.to_si(), dt, edges, rng):
        pass
    parts["stream"] = (time.perf_counter() - wall, _cpu() - cpu)
    config, initial, t0 = stream
    wall, cpu = time.perf_counter(), _cpu()
    run_filter(config, initial, t0, epochs)
    parts["filter"] = (time.perf_counter() - wall, _cpu() - cpu)
    out = {"imports_cpu_s": imports, "epochs": len(epochs)}
    for name, (w, c) in parts.items():
        out[f"{name}_s"], out[f"{name}_cpu_s"] = w, c
    out["floor_cpu_s"] = imports + parts["stream"][1] + parts["filter"][1]
    Path(path).write_text(json.dumps(out))


class _Captured(Exception):
    """Stops the command once its epochs are captured."""


def run(quick=False, runs=None):
    """Both rows (flat dict); ``quick``: 3 rounds, else 5."""
    runs = runs or (3 if quick else 5)
    return {**spp_vs_rtklib(runs), **run_ekf_vs_floor(runs)}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_whole")
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--floor", type=Path, help="measure the run-ekf floor, write JSON")
    parser.add_argument("--tree", type=Path, help="run the inins of another checkout")
    args = parser.parse_args()
    if args.tree:
        TREE = args.tree.resolve()
    if args.floor:
        floor(args.floor)
    else:
        print(json.dumps(run(runs=args.runs), indent=1))
