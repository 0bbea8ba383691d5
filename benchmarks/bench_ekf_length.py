"""``inins run-ekf`` whole processes over flights of growing length (issue 34, item 1).

``python -m benchmarks.bench_ekf_length [--quick] [--tree DIR]`` prints JSON. The
packaged default scenario (EKF2-FB, 200 Hz with dither, 1 Hz pseudoranges and range
rates, HDF5 + report + summary written) flown as a ground wait, take-off and climb
followed by one straight leg that makes the flight :data:`LENGTHS` long (``--set
flight.legs=...``), on the Walker constellation (``gnss.constellation.source=walker``:
ephemerides for any length; the shipped ABPO day ends 18 h after the default start).

Per length, one untimed process first (bytecode, file cache), then the median of
``runs`` processes of:

- ``peak_rss_mb``: the child's peak resident set (``wait4``'s ``ru_maxrss``);
- ``cpu_s``: user + system CPU of the child (and of any process it waited for).

``rss_longest_over_shortest``: peak RSS of the longest flight over the shortest's
(target <= 1.5: memory flat in flight length beyond a run's fixed footprint).
``cpu_per_hour_*``: the CPU a further flight hour costs, ``(cpu(L) - cpu(L0)) /
(L - L0)`` against the shortest flight ``L0`` (the fixed cost of a process, imports
and cached kernels, cancels); ``cpu_per_hour_spread`` the largest over the smallest
(target <= 1.10: CPU linear in flight length, user + system); ``cpu_per_hour_A_to_B_s``
the same between successive lengths. A series of more than 10,000 rows is written
gzip-compressed (:data:`inins.io.h5layout.LONG_ROWS`): a flight of under 2.8 h writes
its per-epoch series uncompressed, a longer one compressed, which costs some tenths of
a CPU second per flight hour more.
"""

import argparse
import itertools
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LENGTHS = {"10min": 600.0, "1h": 3600.0, "4h": 14400.0, "24h": 86400.0}
"""Flight lengths (s) of ``make bench``."""
QUICK_LENGTHS = {"5min": 300.0, "30min": 1800.0, "2h": 7200.0}
"""Flight lengths (s) of ``make bench-quick``."""
TREE = ROOT
"""The checkout whose ``inins`` runs (``--tree``: e.g. the branch start, for before/after)."""
_START = (
    "{kind: wait, duration_s: 120}, "
    "{kind: takeoff, duration_s: 40, speed_mps: 80}, "
    "{kind: climb, duration_s: 100, climb_rate_mps: 5}"
)


def _legs(length):
    """The ``--set`` value of ``flight.legs`` for a flight of ``length`` seconds."""
    return f"flight.legs=[{_START}, {{kind: straight, duration_s: {length - 260.0:g}}}]"


def _process(length, out):
    """``(peak_rss_mb, cpu_s, wall_s)`` of one ``inins run-ekf`` process on a flight of
    ``length`` seconds."""
    args = [
        sys.executable,
        "-m",
        "inins",
        "run-ekf",
        "-o",
        str(out),
        "--set",
        _legs(length),
        "--set",
        "gnss.constellation.source=walker",
    ]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = str(TREE)
    start = time.perf_counter()
    child = subprocess.Popen(
        args, cwd=TREE, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    stderr = child.stderr.read()
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    child.stderr.close()
    if os.waitstatus_to_exitcode(status) not in (0, 1):  # 1: a check failed, the run is whole
        raise RuntimeError(f"{' '.join(args)} failed:\n{stderr.decode()}")
    return usage.ru_maxrss / 1024.0, usage.ru_utime + usage.ru_stime, wall


def run(quick=False, runs=None):
    """Figures of every length (flat dict); ``quick``: :data:`QUICK_LENGTHS`, 1 run each,
    else :data:`LENGTHS`, 3 runs each (the 24 h once)."""
    lengths = QUICK_LENGTHS if quick else LENGTHS
    out, cpu = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        first = next(iter(lengths.values()))
        _process(first, Path(tmp) / "warm")
        for label, length in lengths.items():
            count = runs or (1 if quick or length > 20000 else 3)
            figures = [_process(length, Path(tmp) / f"{label}{k}") for k in range(count)]
            out[f"{label}_peak_rss_mb"] = statistics.median(f[0] for f in figures)
            out[f"{label}_cpu_s"] = cpu[label] = statistics.median(f[1] for f in figures)
            out[f"{label}_wall_s"] = statistics.median(f[2] for f in figures)
    labels = list(lengths)
    shortest, longest = labels[0], labels[-1]
    out["rss_longest_over_shortest"] = (
        out[f"{longest}_peak_rss_mb"] / out[f"{shortest}_peak_rss_mb"]
    )
    rates = []
    for label in labels[1:]:
        hours = (lengths[label] - lengths[shortest]) / 3600.0
        rate = (cpu[label] - cpu[shortest]) / hours
        out[f"cpu_per_hour_{label}_s"] = rate
        rates.append(rate)
    out["cpu_per_hour_spread"] = max(rates) / min(rates)
    for a, b in itertools.pairwise(labels):  # between successive lengths
        hours = (lengths[b] - lengths[a]) / 3600.0
        out[f"cpu_per_hour_{a}_to_{b}_s"] = (cpu[b] - cpu[a]) / hours
    return out


if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_ekf_length")
    parser.add_argument("--quick", action="store_true", help="5 min / 30 min / 2 h, one run")
    parser.add_argument("--runs", type=int, help="processes per length (median)")
    parser.add_argument("--tree", type=Path, help="run the inins of another checkout")
    args = parser.parse_args()
    if args.tree:
        TREE = args.tree.resolve()
    print(json.dumps(run(args.quick, args.runs), indent=1))
