"""Issue 7 items 3-5 through the command: free navigation refused, the same result names
at every table heading, gyrocompassing refused where cos(lat) is too small for the bias,
a warning where its heading error is large, and ETT named as ETT."""

import json

import pytest
from typer.testing import CliRunner

from inins.cli import app
from inins.commands import find_command
from inins.commands.execute import execute
from tests.helpers import CONFIGS

CASE1 = CONFIGS / "paper000" / "case1-no-disturbance.yaml"
FAST = ["simulate.imu.sample_rate_hz=20"]


def run(*args):
    return CliRunner().invoke(app, ["calibrate-bias", *map(str, args)])


def summary(*overrides, config=CASE1):
    return execute(find_command("calibrate-bias"), config, [*FAST, *overrides]).summary


def test_free_navigation_is_refused_naming_the_key(tmp_path):
    result = run(CASE1, "-o", tmp_path, "--set", "navigation.mode=free")
    assert result.exit_code == 2, result.output
    assert "navigation.mode" in result.output and "stationary" in result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "summary.json").exists()


def test_result_names_are_the_same_at_every_table_heading():
    """A heading sweep is a table with fixed columns: at 0 and 180 deg body x points east at
    A, at 90 and 270 deg body y does; the names do not move, the values go null/non-null."""
    keys, east_of = {}, {}
    for heading in (0, 90, 180, 270):
        s = summary(f"simulate.table.base_azimuth_deg={heading}")
        keys[heading] = (sorted(s["results"]), sorted(s["truth"]))
        res = s["results"]
        east_of[heading] = "x" if res["beta_x_eq44_dph"] is not None else "y"
        assert res["beta_x_dph"] is not None and res["beta_y_dph"] is not None
        assert res["beta_z_dph"] is None and res["mount_z_arcsec"] is None
    assert all(k == keys[0] for k in keys.values())
    assert east_of == {0: "x", 90: "y", 180: "x", 270: "y"}


@pytest.mark.parametrize(
    "overrides",
    [
        ["simulate.site.lat_deg=90"],
        ["simulate.site.lat_deg=80", "simulate.imu.gyro.bias_dph=[1.0, 1.0, 0.0]"],
        ["simulate.site.lat_deg=89.9", "simulate.imu.gyro.bias_dph=[0.01, 0.01, 0.0]"],
    ],
)
def test_gyrocompass_refused_where_cos_lat_is_too_small(tmp_path, overrides):
    result = run(CASE1, "-o", tmp_path, *[a for o in overrides for a in ("--set", o)])
    assert result.exit_code == 2, result.output
    assert "alignment.method" in result.output and "ett" in result.output
    assert "Traceback" not in result.output


def test_stated_bias_bound_refuses_before_calibrating(tmp_path):
    """With a data file the bound comes from the scenario (alignment.gyro_bias_bound_dph)."""
    result = run(
        CASE1,
        "-o",
        tmp_path,
        "--set",
        "alignment.gyro_bias_bound_dph=4.0",  # W cos 37 deg = 12 deg/h: 4 deg/h is fine
        "--set",
        "simulate.imu.sample_rate_hz=20",
    )
    assert result.exit_code == 0, result.output
    result = run(CASE1, "-o", tmp_path, "--set", "alignment.gyro_bias_bound_dph=7.0")
    assert result.exit_code == 2 and "alignment.method" in result.output


def test_large_heading_error_warns_and_still_holds(tmp_path):
    result = run(
        CASE1,
        "-o",
        tmp_path,
        "--set",
        "simulate.imu.gyro.bias_dph=[1.0, 1.0, 0.0]",
        "--set",
        "simulate.imu.sample_rate_hz=50",
    )
    assert result.exit_code == 0, result.output
    report = (tmp_path / "calibrate-bias.txt").read_text()
    # atan2(b_E, W cos lat + b_N) = atan2(1, 12.01 + 1) = 4.39 deg
    assert "heading error is 4.39 deg" in report and "exact rotation model" in report
    s = json.loads((tmp_path / "summary.json").read_text())
    heading = s["results"]["initial_heading_err_deg"]
    assert heading == pytest.approx(s["truth"]["initial_heading_err_deg"], abs=2.0 / 3600)  # 2"
    for axis in "xy":
        err = s["results"][f"beta_{axis}_dph"] - s["truth"][f"beta_{axis}_dph"]
        assert abs(err) < 1e-3 * abs(s["truth"][f"beta_{axis}_dph"])


def test_ett_alignment_is_called_ett(tmp_path):
    result = run(CONFIGS / "paper000" / "case4-pitch-mount-ett.yaml", "-o", tmp_path)
    assert result.exit_code == 0, result.output
    report = (tmp_path / "calibrate-bias.txt").read_text()
    assert "alignment: ETT over" in report and "known heading" not in report


def test_three_axis_scenario_gives_beta_z_with_the_same_names(tmp_path):
    result = run(
        CONFIGS / "calibrate-bias" / "three-axis.yaml",
        "-o",
        tmp_path,
        "--set",
        "simulate.imu.sample_rate_hz=20",
    )
    assert result.exit_code == 0, result.output  # its checks: |err| < 4 u on x, y, z
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["results"]["beta_z_dph"] is not None and s["results"]["beta_z_u_dph"] is not None
    assert sorted(s["results"]) == sorted(summary()["results"])
    report = (tmp_path / "calibrate-bias.txt").read_text()
    assert "second return sequence (pitch gimbal at 90 deg" in report
