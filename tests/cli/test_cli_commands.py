"""``inins schema``, ``inins show``, the real command table, a light ``--help``."""

import importlib
import inspect
import json
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from inins.cli import app as real_app
from inins.commands import COMMANDS, load_command
from inins.scenario.base import field_doc_problems

HEAVY = ("numpy", "scipy", "numba", "h5py", "pydantic", "yaml")


def test_schema_of_fake_command(invoke):
    result = invoke("schema", "fake", "--json")
    assert result.exit_code == 0, result.output
    schema = json.loads(result.stdout)
    props = schema["properties"]
    assert props["bias_dph"]["unit"] == "deg/h"
    assert props["duration_s"]["unit"] == "s"
    assert "[s]" in props["duration_s"]["description"]
    assert {"seed", "checks", "name"} <= set(props)
    assert schema["additionalProperties"] is False


def test_schema_of_unknown_and_placeholder(invoke):
    result = invoke("schema", "nope")
    assert result.exit_code == 2 and "unknown command 'nope'" in result.stderr
    result = invoke("schema", "fake-todo")
    assert result.exit_code == 4 and "not yet available" in result.stderr


def test_show_lists_summary_and_datasets(invoke, tmp_path):
    invoke("fake", "-o", tmp_path, "--set", "duration_s=1.5")
    result = invoke("show", tmp_path / "fake.h5")
    assert result.exit_code == 0, result.output
    out = result.stdout
    for part in (
        "command",
        "configs/fake/default.yaml",
        "duration_s=1.5",
        "bias_x_dph",
        "imu/gyro",
        "150x3",
        "rad/s",
        "angular rate",
        "steps/label",
    ):
        assert part in out
    as_json = invoke("show", tmp_path / "fake.h5", "--json")
    assert json.loads(as_json.stdout) == json.loads((tmp_path / "summary.json").read_text())
    scenario = invoke("show", tmp_path / "fake.h5", "--scenario")
    assert "--set duration_s=1.5" in scenario.stdout


def test_show_bad_files(invoke, tmp_path):
    result = invoke("show", tmp_path / "none.h5")
    assert result.exit_code == 2 and "none.h5: file not found" in result.stderr
    (tmp_path / "text.h5").write_text("not hdf5")
    result = invoke("show", tmp_path / "text.h5")
    assert result.exit_code == 2 and "cannot read as HDF5" in result.stderr
    assert "Traceback" not in result.output


def test_every_command_has_help():
    result = CliRunner().invoke(real_app, ["--help"])
    assert result.exit_code == 0
    for code in (
        "0 done",
        "1 a check failed",
        "2 bad input",
        "3 internal error",
        "130 interrupted",
    ):
        assert code in " ".join(result.stdout.split())
    for spec in COMMANDS:
        assert spec.name in result.stdout
        sub = CliRunner().invoke(real_app, [spec.name, "--help"])
        assert sub.exit_code == 0 and "--set" in sub.stdout
        assert "summary.json" in sub.stdout
    for name in ("schema", "show"):
        assert name in result.stdout


@pytest.mark.parametrize("spec", COMMANDS, ids=lambda s: s.name)
def test_registered_scenarios_are_documented(spec):
    """Every key of every implemented command's scenario has a description and unit."""
    module = load_command(spec)
    from inins.scenario.base import ScenarioModel

    assert issubclass(module.SCENARIO_MODEL, ScenarioModel)
    assert field_doc_problems(module.SCENARIO_MODEL) == []


def test_command_modules_follow_the_interface():
    for spec in COMMANDS:
        module = importlib.import_module(spec.module_name)
        assert hasattr(module, "SCENARIO_MODEL") and hasattr(module, "run")
        params = inspect.signature(module.run).parameters
        assert list(params)[:2] == ["scenario", "seed"], spec.name
        for name in ("sink", "progress"):
            assert params[name].kind is inspect.Parameter.KEYWORD_ONLY, (spec.name, name)


def _run_python(code):
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return out.stdout


def test_cli_import_is_light():
    out = _run_python(
        f"import sys, inins.cli; print(' '.join(m for m in {HEAVY!r} if m in sys.modules))"
    )
    assert out.strip() == ""


def test_python_m_inins_version():
    out = subprocess.run(
        [sys.executable, "-m", "inins", "--version"], capture_output=True, text=True, check=True
    )
    assert out.stdout.startswith("inins ")


def test_every_registered_command_is_available():
    assert [s.name for s in COMMANDS if not s.available] == []
