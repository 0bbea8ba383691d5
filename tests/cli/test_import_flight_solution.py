"""``inins import-flight`` with ``format: solution``: the lc-drive RTKLIB solution file
(packaged data/lc-drive/, BSD-3-Clause) joined to its IMU log in the recorded-solution
layout, then ``run-ekf`` post with ``format: recorded`` on that file gives the result of
the direct ``post:`` scenario; bad solution files exit 2 naming file and line."""

import gzip
import json
import re

import pytest
from typer.testing import CliRunner

from inins.cli import app
from tests.helpers import CONFIGS

RUN = CONFIGS / "run-ekf"
DATA = CONFIGS.parent / "data" / "lc-drive"
IMU = """  file: {imu}
  accel_columns: [0, 1, 2]
  gyro_columns: [3, 4, 5]
  time_column: 6
  time_scale_s: 0.001
  accel_unit: g
  gyro_unit: dps
  axes: [-x, y, -z]
  rate_hz: 100
"""


def invoke(*args):
    return CliRunner().invoke(app, [*map(str, args)])


def _import_scenario(tmp_path, pos=None, extra=""):
    pos = pos or DATA / "gnss_1934_sf.pos.gz"
    text = (
        "format: solution\nsolution_imu:\n"
        + IMU.format(imu=DATA / "imu_1934.csv.gz")
        + f"solution_gnss:\n  file: {pos}\n  format: rtklib\n"
        + extra
    )
    path = tmp_path / "import.yaml"
    path.write_text(text)
    return path


def _recorded_scenario(tmp_path, h5):
    text = (RUN / "lc-drive-15s.yaml").read_text()
    text = re.sub(r"  imu:\n(    .*\n)+", f"  imu:\n    file: {h5}\n    format: recorded\n", text)
    text = re.sub(
        r"  gnss:\n(    .*\n)+",
        f"  gnss:\n    file: {h5}\n    format: recorded\n    q_flags: [1, 2]\n"
        "    use_velocity: false\n",
        text,
    )
    path = tmp_path / "recorded.yaml"
    path.write_text(text)
    return path


def _results(out):
    return json.loads((out / "summary.json").read_text())["results"]


def test_import_then_run_ekf_gives_the_direct_result(tmp_path):
    """Both paths read the same SI arrays (HDF5 float64 is lossless) and run the same
    filter, so every result but the wall times agrees to 1e-9 relative (measured: all
    30 equal bit for bit; forward / smoothed outage drift RMS 6.62 / 0.43 m)."""
    out = invoke("import-flight", _import_scenario(tmp_path), "-o", tmp_path / "imp")
    assert out.exit_code == 0, out.output
    imp = _results(tmp_path / "imp")
    assert imp["epochs"] == 2197 and imp["imu_samples"] == 54860
    h5 = tmp_path / "imp" / "import-flight.h5"
    out = invoke("run-ekf", _recorded_scenario(tmp_path, h5), "-o", tmp_path / "rec")
    assert out.exit_code == 0, out.output
    out = invoke("run-ekf", RUN / "lc-drive-15s.yaml", "-o", tmp_path / "direct")
    assert out.exit_code == 0, out.output
    a, b = _results(tmp_path / "rec"), _results(tmp_path / "direct")
    assert set(a) == set(b)
    for key in a:
        if key.endswith("wall_s") or b[key] is None:
            continue
        assert a[key] == pytest.approx(b[key], rel=1e-9, abs=1e-12), key
    assert 4.5 < a["post_fwd_drift_hor_rms_m"] < 9.0
    assert a["post_sm_drift_hor_rms_m"] < 0.6


def test_run_ekf_refuses_a_recorded_flight_file(tmp_path):
    """A file of another layout given as recorded: exit 2 naming the file and '/'."""
    bogus = tmp_path / "x.h5"
    import h5py

    with h5py.File(bogus, "w") as f:
        f.attrs["layout"] = "inins-recorded-flight"
        f.attrs["layout_version"] = 1
    out = invoke("run-ekf", _recorded_scenario(tmp_path, bogus), "-o", tmp_path / "o")
    assert out.exit_code == 2, out.output
    assert "x.h5" in out.stderr and "not a recorded-solution file" in out.stderr


def _pos_lines():
    return gzip.open(DATA / "gnss_1934_sf.pos.gz", "rt").read().splitlines(keepends=True)


@pytest.mark.parametrize(
    ("kind", "expect"),
    [
        ("backwards", ["sol.pos:", "does not increase"]),
        ("sigma", ["sol.pos:", "sigma must be > 0"]),
        ("column", ["sol.pos:", "unknown column 'colour'"]),
        ("no_overlap", ["imu_t0_sow", "no overlap"]),
    ],
)
def test_bad_solution_file_exit_2_nothing_written(tmp_path, kind, expect):
    lines = _pos_lines()
    header = sum(1 for s in lines if s.startswith("%"))
    extra = ""
    if kind == "backwards":
        i = header + 100
        lines[i], lines[i + 1] = lines[i + 1], lines[i]
    elif kind == "sigma":
        f = lines[header + 5].split()
        f[8] = "-0.0100000"  # sdn
        lines[header + 5] = " ".join(f) + "\n"
    elif kind == "column":
        j = next(i for i, s in enumerate(lines) if s.startswith("%  GPST"))
        lines[j] = lines[j].replace("ratio", "colour")
    else:  # the IMU declared to start three days after the drive
        extra = "imu_t0_sow: 500000.0\n"
    pos = tmp_path / "sol.pos"
    pos.write_text("".join(lines))
    out = invoke("import-flight", _import_scenario(tmp_path, pos, extra), "-o", tmp_path / "o")
    assert out.exit_code == 2, out.output
    for text in expect:
        assert text in out.stderr, out.stderr
    if kind in ("backwards", "sigma", "column"):
        assert re.search(r"sol\.pos:\d+", out.stderr), out.stderr
    assert not (tmp_path / "o").exists() or list((tmp_path / "o").iterdir()) == []


def test_recorded_flight_reader_refuses_a_solution_file(tmp_path):
    """The two layouts stay apart: run-ekf's raw-observation reader (recorded-flight,
    version 1, unchanged) names the file and '/' for a recorded-solution file."""
    from inins.exceptions import InputError
    from inins.io.flight_layout import read_flight

    out = invoke("import-flight", _import_scenario(tmp_path), "-o", tmp_path / "imp")
    assert out.exit_code == 0, out.output
    with pytest.raises(InputError, match="not a recorded-flight file"):
        read_flight(tmp_path / "imp" / "import-flight.h5")
