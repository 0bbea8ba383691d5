"""``inins noise`` on a long static record, side by side with allantools.

``run()`` writes an HDF5 log (import-log's hdf5 format: one (n, 3) float32 dataset per
sensor, rates in rad/s and m/s^2) of ``HOURS`` h at 1 kHz, six sensors, white noise
plus a random-walk rate, and runs ``inins noise`` on it in a child process (wall time
and peak RSS of the whole process: it streams the file). Then allantools' overlapping
deviation (``oadev``, octave tau, frequency data) runs on the same six series held in
memory, in the same run. The issue's target is 24 h (518 M samples); on the shared
machine the default is ``HOURS = 2`` (43 M samples) and the 24-h figures are
extrapolated linearly in the record length (stated as such in the output keys:
``*_24h_extrapolated_s``). allantools is a benchmark-only dependency; without it the
comparison is skipped.
"""

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

HOURS = 2.0
RATE_HZ = 1000.0
CHUNK = 1 << 20


def write_log(path, hours, seed=0):
    """The HDF5 log and its scenario; returns the number of samples."""
    n = int(hours * 3600 * RATE_HZ)
    rng = np.random.default_rng(seed)
    with h5py.File(path, "w") as f:
        g = f.create_dataset("gyro", (n, 3), dtype="f4", chunks=(min(CHUNK, n), 3))
        a = f.create_dataset("accel", (n, 3), dtype="f4", chunks=(min(CHUNK, n), 3))
        walk = np.zeros(6)
        for k in range(0, n, CHUNK):
            m = min(CHUNK, n - k)
            white = rng.standard_normal((m, 6)) * np.array([1e-4] * 3 + [2e-3] * 3)
            steps = np.cumsum(rng.standard_normal((m, 6)) * 1e-8, axis=0) + walk
            walk = steps[-1]
            out = white + steps
            out[:, 5] += -9.80665
            g[k : k + m] = out[:, :3]
            a[k : k + m] = out[:, 3:]
    return n


SCENARIO = """
log:
  file: {file}
  format: hdf5
  columns: {{gyro: gyro, accel: accel}}
  sample_rate_hz: 1000.0
gyro: {{quantity: rate, unit: rad/s}}
accel: {{quantity: rate, unit: m/s^2}}
site: {{lat_deg: 45.0, lon_deg: 0.0, height_m: 0.0}}
"""


def _noise(scenario, outdir):
    code = (
        "import json, resource, sys, time\n"
        "t = time.perf_counter()\n"
        "from inins.cli import app\n"
        "try:\n"
        f"    app(args=['noise', {str(scenario)!r}, '-o', {str(outdir)!r}], prog_name='inins')\n"
        "except SystemExit as e:\n"
        "    code = e.code\n"
        "print(json.dumps({'wall_s': time.perf_counter() - t, 'exit': code,\n"
        "    'peak_rss_mb': resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        cwd=Path(__file__).resolve().parents[1],
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def _allantools(path, n):
    try:
        import allantools
    except ImportError:
        return None
    start = time.perf_counter()
    with h5py.File(path, "r") as f:
        for name in ("gyro", "accel"):
            data = f[name][()].astype(np.float64)
            for c in range(3):
                allantools.oadev(data[:, c], rate=RATE_HZ, data_type="freq", taus="octave")
    return time.perf_counter() - start


def run(quick=False, hours=None):
    hours = (0.5 if quick else HOURS) if hours is None else hours
    scale = 24.0 / hours
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        log = tmp / "static.h5"
        start = time.perf_counter()
        n = write_log(log, hours)
        write_s = time.perf_counter() - start
        scenario = tmp / "noise.yaml"
        scenario.write_text(SCENARIO.format(file=log))
        _noise(scenario, tmp / "warm")  # compile the kernels once
        ours = _noise(scenario, tmp / "out")
        if ours["exit"]:
            raise RuntimeError(f"inins noise failed: {ours}")
        theirs = _allantools(log, n)
    figures = {
        "hours": hours,
        "samples": 6 * n,
        "write_log_s": write_s,
        "noise_wall_s": ours["wall_s"],
        "noise_peak_rss_mb": ours["peak_rss_mb"],
        "noise_msamples_per_s": 6 * n / ours["wall_s"] / 1e6,
        "noise_24h_extrapolated_s": ours["wall_s"] * scale,
    }
    if theirs is not None:
        figures["allantools_oadev_s"] = theirs
        figures["allantools_24h_extrapolated_s"] = theirs * scale
        figures["speedup_over_allantools"] = theirs / ours["wall_s"]
    return figures


if __name__ == "__main__":
    hours = float(sys.argv[1]) if len(sys.argv) > 1 else None
    print(json.dumps(run(hours=hours), indent=1))
