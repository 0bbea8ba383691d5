"""Resume rules of a sweep: a point already in the journal is skipped, ``--retry-errors``
reruns exactly the points whose last record is an error, and the last record of a key
in the journal wins (a rerun's record replaces the earlier one in the table)."""

import json

from typer.testing import CliRunner

from inins.cli import app
from inins.io.sweep_files import JOURNAL, read_journal
from inins.sweep.engine import run_sweep
from inins.sweep.plan import load_sweep
from tests.sweep.conftest import TINY_SIMULATE, write_sweep


def _failing_sweep(folder):
    # 3 Hz with a 2 Hz truth output raises (truth_rate_hz must divide the sample rate)
    return write_sweep(
        folder,
        command="simulate-table",
        base=str(TINY_SIMULATE),
        grid={"imu.sample_rate_hz": [20, 3], "output.truth_rate_hz": [1, 2]},
    )


def test_journal_last_record_of_a_key_wins(tmp_path):
    lines = [
        {"key": "a", "status": "error", "n": 1},
        {"key": "b", "status": "passed", "n": 2},
        {"key": "a", "status": "passed", "n": 3},
    ]
    (tmp_path / JOURNAL).write_text("".join(json.dumps(r) + "\n" for r in lines))
    journal = read_journal(tmp_path)
    assert journal["a"]["n"] == 3 and journal["b"]["n"] == 2


def test_retry_errors_reruns_only_the_points_that_raised(tmp_path, pool):
    path, out = _failing_sweep(tmp_path), tmp_path / "out"
    plan = load_sweep(path)
    first = run_sweep(plan, out, pool)
    assert (first.ran, first.skipped, first.errors) == (4, 0, 1)
    again = run_sweep(plan, out, pool)  # a plain resume keeps the error
    assert (again.ran, again.skipped, again.errors) == (0, 4, 1)
    retried = run_sweep(plan, out, pool, retry_errors=True)
    assert (retried.ran, retried.skipped, retried.errors) == (1, 3, 1)
    # the journal holds two records of the failed point; the table one per point
    keys = [json.loads(x)["key"] for x in (out / JOURNAL).read_text().splitlines()]
    assert len(keys) == 5 and len(set(keys)) == 4
    assert len(retried.table.records) == 4


def test_a_later_record_replaces_the_earlier_one_on_resume(tmp_path, pool):
    """A point journalled as passed, then as error (a rerun that raised): the resume
    sees the error (retried with --retry-errors), the table shows the error."""
    path, out = _failing_sweep(tmp_path), tmp_path / "out"
    plan = load_sweep(path)
    run_sweep(plan, out, pool)
    journal = read_journal(out)
    good = next(r for r in journal.values() if r["status"] != "error")
    with (out / JOURNAL).open("a") as handle:
        handle.write(json.dumps({**good, "status": "error", "error": "later failure"}) + "\n")
    resumed = run_sweep(plan, out, pool)
    assert (resumed.ran, resumed.errors) == (0, 2)
    errors = [r for r in resumed.table.records if r["status"] == "error"]
    assert any(r["error"] == "later failure" for r in errors)
    retried = run_sweep(plan, out, pool, retry_errors=True)
    assert (retried.ran, retried.errors) == (2, 1)


def test_retry_errors_option_on_the_command_line(tmp_path):
    path, out = _failing_sweep(tmp_path), tmp_path / "out"
    runner = CliRunner()
    first = runner.invoke(app, ["sweep", str(path), "-o", str(out), "-j", "1"])
    assert "1 raised" in first.output, first.output
    plain = runner.invoke(app, ["sweep", str(path), "-o", str(out), "-j", "1"])
    assert "0 run, 4 already finished" in plain.output, plain.output
    retry = runner.invoke(app, ["sweep", str(path), "-o", str(out), "-j", "1", "--retry-errors"])
    assert "1 run, 3 already finished" in retry.output, retry.output
