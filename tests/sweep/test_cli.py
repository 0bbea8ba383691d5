"""``inins sweep`` and ``inins check`` on the command line: exit codes and files."""

import shutil

import pytest
import yaml
from typer.testing import CliRunner

from inins.cli import app
from tests.sweep.conftest import TINY_SIMULATE, write_sweep


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def _sweep_file(folder, **extra):
    content = {
        "command": "simulate-table",
        "base": str(TINY_SIMULATE),
        "grid": {"motion.0.duration_s": [1, 2]},
    }
    content.update(extra)
    return write_sweep(folder, **content)


def test_sweep_runs_prints_aggregates_and_plots(tmp_path):
    pytest.importorskip("matplotlib")
    out = tmp_path / "out"
    result = invoke(
        "sweep", _sweep_file(tmp_path), "-o", out, "-j", "1", "--plot-result", "samples"
    )
    assert result.exit_code == 0, result.output
    assert "2 run, 0 already finished, 0 raised; 2 of 2 points" in result.output
    assert "Sample std" not in result.output and "samples" in result.output
    for name in ("sweep.csv", "sweep.h5", "aggregates.csv", "sweep.txt", "plot-samples.png"):
        assert (out / name).stat().st_size > 0, name
    assert not (out / "runs").exists()


@pytest.mark.parametrize(
    ("extra", "args", "expected"),
    [
        ({"grid": {"imu.gyro.bias": [1, 2]}}, [], "grid.imu.gyro.bias"),
        ({"grid": {"motion.0.duration_s": [1, "x"]}}, [], "expected a number"),
        ({"seeds": 6}, ["--max-points", "10"], "12 points, more than --max-points 10"),
        ({}, ["--plot-result", "samples", "--against", "imu.sample_rate_hz"], "not a swept key"),
    ],
)
def test_bad_sweeps_exit_2_before_anything_runs(tmp_path, extra, args, expected):
    out = tmp_path / "out"
    result = invoke("sweep", _sweep_file(tmp_path, **extra), "-o", out, *args)
    assert result.exit_code == 2, result.output
    assert expected in result.output
    assert not out.exists()


def test_a_failed_check_in_a_point_exits_1(tmp_path):
    path = _sweep_file(tmp_path, set={"checks": ["samples > 130"]})
    result = invoke("sweep", path, "-o", tmp_path / "out", "-j", "1")
    assert result.exit_code == 1, result.output
    # 6.2 s at 20 Hz: 124 samples; a first hold 1 s longer adds 20
    lines = (tmp_path / "out" / "sweep.csv").read_text().splitlines()
    assert [line.split(",")[3] for line in lines[1:]] == ["check-failed", "passed"]


def _scenario(folder, name, **updates):
    data = yaml.safe_load(TINY_SIMULATE.read_text())
    data.update(updates)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def test_check_gates_on_every_scenario_with_checks(tmp_path):
    good = _scenario(tmp_path / "simulate-table", "good.yaml")
    _scenario(tmp_path / "simulate-table", "bad.yaml", checks=["samples > 1000"])
    _scenario(tmp_path / "lab", "inferred.yaml")  # not a command folder: the model decides
    _scenario(tmp_path / "lab", "plain.yaml", checks=[])
    shutil.copy(TINY_SIMULATE, tmp_path / "lab" / "copy.yaml")
    result = invoke("check", tmp_path, "-j", "2")
    assert result.exit_code == 1, result.output
    assert "bad.yaml: check failed: samples > 1000" in result.output
    assert "3 of 4 scenarios passed" in result.output
    assert "skipped 1 file(s) without checks" in result.output
    assert "inferred.yaml (simulate-table" in result.output
    glob = invoke("check", str(tmp_path / "simulate-table" / "g*.yaml"), str(good), "-j", "1")
    assert glob.exit_code == 0, glob.output
    assert "1 of 1 scenarios passed" in glob.output


@pytest.mark.parametrize(
    ("files", "expected"),
    [
        ({"simulate-table/x.yaml": {"imu": {"gyro": {"bias_dhp": 1}}}}, "bias_dhp"),
        ({"lab/y.yaml": {"something": 1}}, "cannot tell which command"),
        ({}, "no such file or folder"),
    ],
)
def test_check_bad_input_exits_2_before_any_run(tmp_path, files, expected):
    for name, updates in files.items():
        _scenario(tmp_path / name.split("/")[0], name.split("/")[1], **updates)
    target = tmp_path if files else tmp_path / "missing"
    result = invoke("check", target)
    assert result.exit_code == 2, result.output
    assert expected in result.output
