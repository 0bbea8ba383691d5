"""inins calibrate-bias through the CLI: files, summary names, bad input."""

import json
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from inins.cli import app

CONFIGS = Path(__file__).parents[2] / "configs"
NAMES = [
    "beta_x_attitude_dph",
    "beta_y_attitude_dph",
    "beta_x_velocity_dph",
    "beta_y_velocity_dph",
    "beta_y_eq38_dph",
    "beta_x_eq44_dph",
    "beta_x_eq45_dph",
    "beta_x_dph",
    "beta_y_dph",
    "initial_heading_err_deg",
]


def run(*args):
    return CliRunner().invoke(app, ["calibrate-bias", *map(str, args)])


def test_packaged_default_writes_results_with_the_issue_names(tmp_path):
    result = run("-o", tmp_path)
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "summary.json").read_text())
    for name in NAMES:
        assert name in summary["results"], name
        if name.startswith("beta"):
            assert name.replace("_dph", "_sigma_dph") in summary["results"]
    assert set(summary["truth"]) >= {"beta_x_dph", "beta_y_dph"}
    report = (tmp_path / "calibrate-bias.txt").read_text()
    assert "automatic choice" in report and "eq. 38" in report
    assert (tmp_path / "calibrate-bias.h5").is_file()


def test_inseparable_case_reports_null_and_recommends_ett(tmp_path):
    result = run(CONFIGS / "paper000" / "case3-pitch-mount.yaml", "-o", tmp_path)
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["results"]["beta_x_dph"] is None
    assert summary["results"]["beta_y_dph"] is not None
    assert "ETT" in (tmp_path / "calibrate-bias.txt").read_text()


def test_paper_numbers_beside_ours(tmp_path):
    result = run(CONFIGS / "paper000" / "case2-roll-mount.yaml", "-o", tmp_path)
    assert result.exit_code == 0, result.output
    report = (tmp_path / "calibrate-bias.txt").read_text()
    assert "paper 000 §3.2 case 2" in report and "0.00352" in report and "-0.0037" in report


def test_table_data_file_input(tmp_path):
    sim = CliRunner().invoke(
        app,
        [
            "simulate-table",
            str(CONFIGS / "simulate-table" / "paper000-case1-no-disturbance.yaml"),
            "-o",
            str(tmp_path),
        ],
    )
    assert sim.exit_code == 0, sim.output
    scenario = tmp_path / "cal.yaml"
    scenario.write_text(
        "data: simulate-table.h5\nchecks:\n"
        "  - abs(err.beta_x_dph) < 0.0005\n  - abs(err.beta_y_dph) < 0.0005\n"
    )
    result = run(scenario, "-o", tmp_path / "out")
    assert result.exit_code == 0, result.output


def test_sequence_without_two_positions_180_deg_apart_is_bad_input(tmp_path):
    scenario = tmp_path / "s.yaml"
    shutil.copy(CONFIGS / "paper000" / "case1-no-disturbance.yaml", scenario)
    result = run(
        scenario,
        "-o",
        tmp_path,
        "--set",
        "simulate.motion.2.angle_deg=90",
        "--set",
        "simulate.motion.4.angle_deg=-90",
    )
    assert result.exit_code == 2
    assert "180 deg apart" in result.output and "Traceback" not in result.output


def test_holds_too_short_is_bad_input(tmp_path):
    result = run(
        CONFIGS / "paper000" / "case1-no-disturbance.yaml",
        "-o",
        tmp_path,
        "--set",
        "alignment.duration_s=1000",
    )
    assert result.exit_code == 2
    assert "too short" in result.output


def test_ett_without_vertical_position_is_bad_input(tmp_path):
    result = run(
        CONFIGS / "paper000" / "case1-no-disturbance.yaml",
        "-o",
        tmp_path,
        "--set",
        "alignment.method=ett",
    )
    assert result.exit_code == 2, result.output
    assert "ett" in result.output.lower() and "Traceback" not in result.output


@pytest.mark.parametrize(
    "key, value", [("alignment.method", "magic"), ("navigation.output_rate_hz", "-1")]
)
def test_scenario_errors_name_the_key(tmp_path, key, value):
    result = run("-o", tmp_path, "--set", f"{key}={value}")
    assert result.exit_code == 2
    assert key.split(".")[-1] in result.output


def test_plot_writes_pngs(tmp_path):
    result = run(CONFIGS / "paper000" / "case1-no-disturbance.yaml", "-o", tmp_path, "--plot")
    assert result.exit_code == 0, result.output
    for name in ("calibrate-bias-roll.png", "calibrate-bias-pitch.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_without_matplotlib_is_a_clear_message(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import fails as if not installed
    result = run("-o", tmp_path, "--plot")
    assert result.exit_code == 2
    assert "matplotlib" in result.output and "inins[plot]" in result.output
    assert not (tmp_path / "summary.json").exists()


def test_plot_on_a_command_without_figures(invoke, tmp_path):
    # every available command draws now (tests/cli/test_plots.py); the fake one does not
    result = invoke("fake", "-o", tmp_path / "out", "--plot")
    assert result.exit_code == 2 and "no figures" in result.output


def test_two_positions_without_return_run_the_two_position_methods(tmp_path):
    """Issue: where other methods can still run, the report warns and marks the
    return-sequence method not applicable (no mount check without the return)."""
    result = run(
        CONFIGS / "paper000" / "case1-no-disturbance.yaml",
        "-o",
        tmp_path,
        "--set",
        "simulate.motion="
        + json.dumps(
            [
                {"kind": "hold", "duration_s": 300, "label": "align"},
                {"kind": "hold", "duration_s": 600, "label": "0deg"},
                {"kind": "rotate", "axis": "yaw", "angle_deg": 180, "rate_dps": 10},
                {"kind": "hold", "duration_s": 600, "label": "180deg"},
            ]
        ),
        "--set",
        "checks=[]",
    )
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "summary.json").read_text())
    res, truth = summary["results"], summary["truth"]
    for name in (
        "beta_x_dph",
        "beta_y_dph",
        "beta_y_eq38_dph",
        "beta_x_eq45_dph",
        "mount_x_arcsec",
    ):
        assert res[name] is None, name
    for axis in "xy":  # noise-free, no disturbance: the two-position methods hold
        assert abs(res[f"beta_{axis}_attitude_dph"] - truth[f"beta_{axis}_dph"]) < 0.0005
    report = (tmp_path / "calibrate-bias.txt").read_text()
    assert "does not return to the first position" in report
