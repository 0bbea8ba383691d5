"""The first hour of use (issue 8, items 9, 12-14): the compile notice, phases, the
schema table, help text, packaging."""

import re
import tomllib
from pathlib import Path

from typer.testing import CliRunner

from inins.cli import _runner
from inins.cli import app as real_app
from inins.cli.schema import schema_dict, schema_rows, schema_table

ROOT = Path(__file__).resolve().parents[2]


def test_schema_table_of_fake_command(invoke, monkeypatch):
    monkeypatch.delenv("COLUMNS", raising=False)  # not a terminal: the unwrapped table
    result = invoke("schema", "fake")
    assert result.exit_code == 0, result.output
    rows = {line.split()[0]: line for line in result.stdout.splitlines()[4:] if line.strip()}
    assert re.search(
        r"^duration_s +number > 0 +s +2\.0 +Length of the run \[s\]$", rows["duration_s"]
    )
    assert re.search(r"^name +text +required +Name of the run$", rows["name"])
    assert "--json for the JSON Schema" in result.stdout


def test_schema_table_of_every_command_covers_every_leaf():
    # simulate-table: the motion steps by kind, the sections by dotted path
    rows = {r[0]: r for r in schema_rows(schema_dict("simulate-table"))}
    assert rows["imu.gyro.bias_dph"][2] == "deg/h"
    assert rows["motion[] (rotate).rate_dps"][1:4] == ("number > 0", "deg/s", "10.0")
    assert rows["motion[]"][3] == "required"
    assert rows["checks"][3] == ""  # has a default (empty list), not required
    for command in ("import-log", "calibrate-bias", "align-ett"):
        text = schema_table(command)
        assert len(text.splitlines()) > 20 and "{" not in text.splitlines()[2]


def test_help_lists_exit_codes():
    result = CliRunner().invoke(real_app, ["--help"])
    text = " ".join(result.stdout.split())
    assert "4 command not available in this version" in text
    assert "3 internal error" in text and "130 interrupted" in text


def test_help_marks_unavailable_commands(invoke):
    """A command of a later version (the fake table's fake-todo) is listed as such and
    exits 4 (every command of the real table is available now)."""
    text = " ".join(invoke("--help").stdout.split())
    assert "(not yet available) A command of a later version" in text
    sub = invoke("fake-todo", "--help")
    assert "running it exits with code 4" in " ".join(sub.stdout.split())
    assert invoke("fake-todo").exit_code == 4


def test_no_bool_placeholders_in_help():
    for args in (["--help"], ["calibrate-bias", "--help"], ["schema", "--help"]):
        result = CliRunner().invoke(real_app, args)
        assert result.exit_code == 0
        assert "<bool>" not in result.stdout and "<int range>" not in result.stdout, args
        assert "--force" in result.stdout or args != ["calibrate-bias", "--help"]


def test_progress_phases_are_labelled(monkeypatch):
    seen = []

    class Recorder:
        def phase(self, name):
            seen.append(name)

        def __call__(self, done, total):
            seen.append((done, total))

    from inins.commands import find_command
    from inins.commands.execute import execute

    execute(
        find_command("import-log"),
        ROOT / "configs/import-log/csv-example.yaml",
        outdir=None,
        progress=Recorder(),
    )
    assert seen[0] == "import"
    assert _runner.EXIT_UNAVAILABLE == 4


def test_configs_ship_without_the_setuptools_warning():
    # include-package-data off: package-data alone says what ships, so setuptools does
    # not take configs/paper000 (a valid identifier) for a package left out.
    conf = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert conf["include-package-data"] is False
    assert conf["package-data"]["inins.configs"] == ["**/*.yaml"]
