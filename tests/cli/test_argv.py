"""The plain command line of a run, parsed without Typer (:mod:`inins.cli._argv`), gives
exactly the arguments Typer's parse gives; every other command line is left to Typer."""

import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from inins.cli import _runner, make_app
from inins.cli._argv import parse_run
from inins.commands import COMMANDS

ROOT = Path(__file__).resolve().parents[2]

PLAIN = [
    ["simulate-table"],
    ["simulate-table", "scenario.yaml"],
    ["calibrate-bias", "-o", "out"],
    ["align-ett", "--outdir=out/x y"],
    ["run-ekf", "--outdir", "out", "--seed", "5"],
    ["calibrate-bias", "--set", "a.b=1", "--set=c=2", "--seed=007"],
    ["observability", "x.yaml", "--debug", "--plot", "--force", "-o", "o"],
    ["run-ekf", "-o", "o", "s.yaml", "--set", "k=[1, 2]", "--set", "motion.3.duration_s=60"],
    ["noise", "--seed", "9223372036854775807"],
    ["noise", "--seed", "9999999999999999999"],  # out of range: execute says so
    ["import-log", "--set", "a=-1", "--set", "b= x"],
    ["calibrate-imu", "dir/../s.yaml", "--force"],
]
TYPER_ONLY = [
    [],
    ["--help"],
    ["--version"],
    ["schema", "simulate-table"],
    ["show", "x.h5"],
    ["sweep", "s.yaml"],
    ["simulate-table", "--help"],
    ["simulate-table", "-h"],
    ["simulate-table", "--seed", "-1"],
    ["simulate-table", "--seed", "x"],
    ["simulate-table", "--seed", " 5"],
    ["simulate-table", "--seed", "0x10"],
    ["simulate-table", "-o"],
    ["simulate-table", "-oout"],
    ["simulate-table", "-o=out"],
    ["simulate-table", "--outdir="],
    ["simulate-table", "-o", "--debug"],
    ["simulate-table", "a.yaml", "b.yaml"],
    ["simulate-table", "--debug", "--debug"],
    ["simulate-table", "-o", "a", "--outdir", "b"],
    ["simulate-table", "--seed", "1", "--seed", "2"],
    ["simulate-table", "--", "x.yaml"],
    ["simulate-table", ""],
    ["simulate-table", "-"],
    ["simulate-table", "--debug=1"],
    ["simulate-table", "--unknown"],
    ["simulate-table", "--set"],
    ["simulate-table", "bad\udcffname.yaml"],
    ["no-such-command"],
]


def _typer_arguments(monkeypatch, argv):
    """The arguments Typer's parse of ``argv`` hands to ``run_command``."""
    seen = []

    def fake_run_command(spec, scenario, outdir, overrides, seed, debug, plot, force):
        seen.append(
            (
                spec,
                {
                    "scenario": scenario,
                    "outdir": outdir,
                    "overrides": overrides,
                    "seed": seed,
                    "debug": debug,
                    "plot": plot,
                    "force": force,
                },
            )
        )
        return 0

    monkeypatch.setattr(_runner, "run_command", fake_run_command)
    result = CliRunner().invoke(make_app(), argv)
    assert result.exit_code == 0, result.output
    (parsed,) = seen
    return parsed


@pytest.mark.parametrize("argv", PLAIN, ids=" ".join)
def test_a_plain_run_parses_as_typer_parses_it(monkeypatch, argv):
    spec, args = parse_run(argv, COMMANDS)
    typer_spec, typer_args = _typer_arguments(monkeypatch, argv)
    assert spec is typer_spec
    assert args == typer_args
    assert all(type(args[k]) is type(typer_args[k]) for k in args)


@pytest.mark.parametrize("argv", TYPER_ONLY, ids=repr)
def test_any_other_command_line_is_left_to_typer(argv):
    assert parse_run(argv, COMMANDS) is None


def test_a_plain_run_loads_no_typer_and_an_error_still_exits_2(tmp_path):
    code = (
        "import sys; from inins.cli import main; sys.argv = ['inins', *sys.argv[1:]]\n"
        "try:\n    main()\n"
        "except SystemExit as exc:\n"
        "    print(exc.code, 'typer' in sys.modules, 'click' in sys.modules)\n"
    )
    bad = tmp_path / "bad.yaml"
    bad.write_text("imu: {sample_rate_hz: -5}\n")
    done = subprocess.run(
        [sys.executable, "-c", code, "simulate-table", str(bad), "-o", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        check=False,
        cwd=ROOT,
    )
    assert done.stdout.split() == ["2", "False", "False"], done.stdout + done.stderr
    assert done.stderr.startswith("inins simulate-table: error: ")
    assert str(bad) in done.stderr
