"""``inins align-ett`` end to end: the packaged default, a table-data file, bad input."""

import json

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from inins.cli import app
from inins.commands._table import read_ett_result
from inins.core import rotation
from inins.core.units import ARCSEC
from inins.exceptions import InputError

RESULTS = (
    "heading_deg",
    "heading_sigma_deg",
    "time_used_s",
    "gyrocompass_heading_deg",
    "gyrocompass_heading_err_deg",
    "heading_err_deg",
    "azimuth_offset_arcsec",
    "tilt_x_arcsec",
    "tilt_y_arcsec",
)

SIMULATE = """\
seed: 5
site: {lat_deg: 45.0, lon_deg: 10.0, height_m: 100.0}
table: {gimbals: [yaw, pitch], base_azimuth_deg: 30.0, encoder_noise_arcsec: 0.5}
mount: {imu_axes: [right, forward, up], misalignment_arcsec: [10.0, -20.0, 72.0]}
imu:
  sample_rate_hz: 100
  accel: {bias_ug: 10.0, vrw_ug_rthz: 5.0, pulse_weight_ug_s: 10.0}
motion:
  - {kind: rotate, axis: pitch, angle_deg: 90}
  - {kind: hold, duration_s: 30, label: up}
  - {kind: rotate, axis: pitch, angle_deg: -90}
  - {kind: hold, duration_s: 30, label: flat}
"""


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def test_default_scenario_writes_the_three_files(tmp_path):
    result = invoke("align-ett", "-o", tmp_path)
    assert result.exit_code == 0, result.output
    names = {p.name for p in tmp_path.iterdir()}
    assert names == {"align-ett.h5", "align-ett.txt", "summary.json"}
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["command"] == "align-ett" and summary["passed"]
    assert set(RESULTS) <= set(summary["results"])
    assert "heading_deg" in summary["truth"]
    # 000's IMU (x right) on a table facing north, 72 arcsec off in azimuth (the 10 and
    # -20 arcsec tilts move the Euler heading by 5e-4 arcsec)
    assert summary["truth"]["heading_deg"] == pytest.approx(90.0 - 72.0 / 3600.0, abs=1e-6)
    report = (tmp_path / "align-ett.txt").read_text()
    assert "B = W A U^-1" in report and "gyrocompass" in report
    ett = read_ett_result(tmp_path / "align-ett.h5")
    assert np.degrees(ett.heading) == pytest.approx(summary["results"]["heading_deg"], abs=1e-12)
    assert ett.heading_at(ett.level_angles) == pytest.approx(ett.heading, abs=1e-12)
    with h5py.File(tmp_path / "align-ett.h5") as f:
        assert f["ett/mu"].attrs["units"] == "rad"
        assert f["ett"].attrs["level_label"] == "level"


def test_table_data_file_and_read_back(tmp_path):
    (tmp_path / "sim.yaml").write_text(SIMULATE)
    done = invoke("simulate-table", tmp_path / "sim.yaml", "-o", tmp_path / "sim")
    assert done.exit_code == 0, done.output
    (tmp_path / "ett.yaml").write_text(  # the data path is relative to the scenario file
        "data: sim/simulate-table.h5\nimu_axes: [right, forward, up]\npositions: {settle_s: 2}\n"
        "checks: ['abs(err.heading_deg) < 4 * heading_sigma_deg']\n"
    )
    result = invoke("align-ett", tmp_path / "ett.yaml", "-o", tmp_path / "out")
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    res = summary["results"]
    # accelerometer bias 10 ug on x: heading error -10 ug / g = -2.06 arcsec
    assert res["heading_err_deg"] * 3600 == pytest.approx(-2.06, abs=0.3)
    assert res["time_used_s"] == pytest.approx(2 * 30 + 9.5, abs=0.1)
    ett = read_ett_result(tmp_path / "out" / "align-ett.h5")
    truth = summary["truth"]["heading_deg"]
    assert rotation.wrap_angle(ett.heading - np.radians(truth)) / ARCSEC == pytest.approx(
        res["heading_err_deg"] * 3600, abs=1e-6
    )


@pytest.mark.parametrize(
    ("args", "fragments"),
    [
        (
            ("--set", "simulate.motion=[{kind: hold, duration_s: 30, label: a}]"),
            ("align-ett (ETT", "no vertical position", "positions.vertical_label"),
        ),
        (
            ("--set", "positions.vertical_label=nope"),
            ("no hold labelled 'nope'", "'start', 'vertical', 'level'"),
        ),
        (("--set", "data=t.h5"), ("data: give either data", "not both")),
    ],
)
def test_bad_input_exits_2(tmp_path, args, fragments):
    result = invoke("align-ett", "-o", tmp_path, *args)
    assert result.exit_code == 2, result.output
    for fragment in fragments:
        assert fragment in result.stderr
    assert "Traceback" not in result.output
    assert list(tmp_path.iterdir()) == []


def test_read_ett_result_of_another_file(tmp_path):
    (tmp_path / "sim.yaml").write_text(SIMULATE)
    invoke("simulate-table", tmp_path / "sim.yaml", "-o", tmp_path)
    with pytest.raises(InputError, match="not an align-ett results file"):
        read_ett_result(tmp_path / "simulate-table.h5")
