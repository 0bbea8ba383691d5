"""The file contract of spec §1, driven through the CLI with a fake command."""

import json
import re

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from inins.io.provenance import PROVENANCE_KEYS

OUTPUTS = ("fake.h5", "fake.txt", "summary.json")


def _no_partials(outdir):
    return not [p.name for p in outdir.iterdir() if ".partial-" in p.name]


def test_default_scenario_writes_three_files(invoke, tmp_path):
    out = tmp_path / "out"
    result = invoke("fake", "-o", out)
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.iterdir()) == sorted(OUTPUTS)
    assert "done" in result.stdout and "PASSED: 2 of 2" in result.stdout
    assert result.stderr == ""


def test_datasets_carry_units_frame_description(invoke, tmp_path):
    invoke("fake", "-o", tmp_path)
    with h5py.File(tmp_path / "fake.h5") as f:
        gyro = f["imu/gyro"]
        assert gyro.shape == (200, 3)
        assert (gyro.attrs["units"], gyro.attrs["frame"]) == ("rad/s", "b")
        assert gyro.attrs["description"] == "angular rate"
        assert f["imu/time"].attrs["units"] == "s"
        assert [s.decode() for s in f["steps/label"][()]] == ["hold", "turn"]
        assert f["imu"].attrs["rate_hz"] == 100.0
        np.testing.assert_array_equal(f["imu"].attrs["errors.bias_rad_s"], gyro[0])
        assert f.attrs["name"] == "demo"


def test_provenance_attributes(invoke, tmp_path, configs):
    invoke("fake", "-o", tmp_path)
    with h5py.File(tmp_path / "fake.h5") as f:
        attrs = dict(f.attrs)
    assert set(PROVENANCE_KEYS) | {"summary_json"} <= set(attrs)
    assert attrs["command"] == "fake"
    assert attrs["seed"] == 0
    assert attrs["scenario_source"] == "configs/fake/default.yaml"
    assert attrs["scenario_yaml"] == (configs / "fake" / "default.yaml").read_text()
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", attrs["created_utc"])
    assert attrs["numpy_version"] == np.__version__
    assert json.loads(attrs["summary_json"]) == json.loads((tmp_path / "summary.json").read_text())


def test_summary_json_shape(invoke, tmp_path):
    invoke("fake", "-o", tmp_path)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert list(summary) == [
        "command",
        "inins_version",
        "scenario",
        "seed",
        "results",
        "truth",
        "checks",
        "passed",
    ]
    results = summary["results"]
    assert results["n_samples"] == 200 and isinstance(results["n_samples"], int)
    assert isinstance(results["bias_y_dph"], float)  # from np.float32
    assert results["beta_z_dph"] is None and results["nan_dph"] is None
    assert summary["truth"] == {"bias_x_dph": 0.01, "bias_y_dph": -0.02}
    assert [c["passed"] for c in summary["checks"]] == [True, True]
    assert summary["checks"][0]["name"] == "abs(err.bias_x_dph) < 0.001"
    assert summary["checks"][0]["value"] < 0.001
    assert summary["passed"] is True


def test_report_text(invoke, tmp_path):
    invoke("fake", "-o", tmp_path)
    text = (tmp_path / "fake.txt").read_text()
    assert "\x1b[" not in text
    for part in (
        "inins fake report",
        "configs/fake/default.yaml",
        "seed",
        "Gyro bias",
        "[deg/h]",
        "fake warning",
        "abs(err.bias_x_dph) < 0.001",
        "PASSED",
    ):
        assert part in text


def test_failed_check_exits_1(invoke, tmp_path):
    result = invoke("fake", "-o", tmp_path, "--set", "checks=[bias_x_dph > 1, n_samples > 0]")
    assert result.exit_code == 1, result.output
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert [c["passed"] for c in summary["checks"]] == [False, True]
    assert summary["passed"] is False
    assert "FAILED: 1 of 2" in (tmp_path / "fake.txt").read_text()


def test_not_applicable_result_fails_check_with_reason(invoke, tmp_path):
    result = invoke("fake", "-o", tmp_path, "--set", "checks=[beta_z_dph < 1]")
    assert result.exit_code == 1
    check = json.loads((tmp_path / "summary.json").read_text())["checks"][0]
    assert check["passed"] is False and "not applicable" in check["reason"]


def test_overrides_are_used_and_recorded(invoke, tmp_path):
    result = invoke(
        "fake",
        "-o",
        tmp_path,
        "--set",
        "duration_s=3",
        "--set",
        "bias_dph.1=0.5",
        "--set",
        "checks=[]",
    )
    assert result.exit_code == 0, result.output
    with h5py.File(tmp_path / "fake.h5") as f:
        assert f["imu/gyro"].shape == (300, 3)
        text = f.attrs["scenario_yaml"]
        assert list(f.attrs["scenario_overrides"]) == [
            "duration_s=3",
            "bias_dph.1=0.5",
            "checks=[]",
        ]
    assert "--set bias_dph.1=0.5" in text and "duration_s: 3" in text
    assert "override  --set duration_s=3" in (tmp_path / "fake.txt").read_text()
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["truth"]["bias_y_dph"] == 0.5


@pytest.mark.parametrize(
    ("args", "yaml_seed", "expected"),
    [((), None, 0), ((), 7, 7), (("--seed", "11"), 7, 11), (("--seed", "0"), 7, 0)],
)
def test_seed_precedence(invoke, tmp_path, args, yaml_seed, expected):
    scenario = tmp_path / "s.yaml"
    scenario.write_text("name: s\n" + (f"seed: {yaml_seed}\n" if yaml_seed is not None else ""))
    result = invoke("fake", scenario, "-o", tmp_path / "out", *args)
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["seed"] == expected == summary["results"]["seed_used"]
    with h5py.File(tmp_path / "out" / "fake.h5") as f:
        assert f.attrs["seed"] == expected


def test_user_scenario_source_name(invoke, tmp_path):
    scenario = tmp_path / "mine.yaml"
    scenario.write_text("name: mine\n")
    invoke("fake", scenario, "-o", tmp_path / "out")
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["scenario"] == str(scenario)


def test_streaming_command(invoke, tmp_path):
    result = invoke("fake-stream", "-o", tmp_path, "--set", "duration_s=250")
    assert result.exit_code == 0, result.output
    with h5py.File(tmp_path / "fake-stream.h5") as f:
        long = f["imu/long"]
        assert long.shape == (25_000, 3)
        assert long.compression == "gzip" and long.shuffle
        assert (long.attrs["units"], long.attrs["frame"]) == ("rad/s", "b")
        assert long.attrs["dt_s"] == pytest.approx(0.01)
        assert f["imu/rate"][0] == 100.0
    assert _no_partials(tmp_path)


def test_outputs_replace_earlier_results(invoke, tmp_path):
    invoke("fake", "-o", tmp_path, "--set", "duration_s=1")
    invoke("fake", "-o", tmp_path, "--set", "duration_s=2")
    with h5py.File(tmp_path / "fake.h5") as f:
        assert f["imu/gyro"].shape == (200, 3)
    assert _no_partials(tmp_path)


def test_a_rerun_leaves_no_file_of_the_earlier_run(tmp_path):
    """A folder holds one run's files: a certificate or figure of an earlier run that
    this run does not write is removed in the same commit (a lab would otherwise print
    the seed-1 certificate beside seed-2 results), and the report lists the files."""
    from inins.cli import app

    runner = CliRunner()
    first = runner.invoke(app, ["calibrate-imu", "-o", str(tmp_path), "--plot", "--seed", "1"])
    assert first.exit_code == 0, first.output
    assert (tmp_path / "calibrate-imu-certificate.html").exists()
    assert (tmp_path / "calibrate-imu-residuals.png").exists()
    (tmp_path / "notes.txt").write_text("the user's own file")
    second = runner.invoke(app, ["calibrate-imu", "-o", str(tmp_path), "--seed", "2"])
    assert second.exit_code == 0, second.output
    held = sorted(p.name for p in tmp_path.iterdir())
    written = [
        "calibrate-imu-compensation.yaml",
        "calibrate-imu.h5",
        "calibrate-imu.txt",
        "summary.json",
    ]
    assert held == sorted([*written, "notes.txt"])
    report = (tmp_path / "calibrate-imu.txt").read_text()
    listed = report.split("Files\n-----\n", 1)[1].split("\n\n")[0].splitlines()
    assert sorted(line.removeprefix("- ") for line in listed) == written
