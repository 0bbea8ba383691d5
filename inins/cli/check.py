"""``inins check PATH...``: the CI gate over scenario files with ``checks:``."""

from pathlib import Path
from typing import Annotated

import typer

from inins.cli._runner import (
    EXIT_BAD_INPUT,
    EXIT_CHECK_FAILED,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OK,
    echo_err,
    guarded,
)

_HELP = (
    "Run every scenario with checks: in PATH (files, folders, globs) and report. The "
    "command of a file is its folder's name (configs/<command>/), else the one command "
    "whose scenario accepts it. Files without checks: are skipped. Exit codes: 0 every "
    "check passed, 1 a check failed (listed), 2 bad input (nothing runs if a file is bad; "
    "also a run that stops on bad input), 3 a run raised an internal error, 130 "
    "interrupted (the scenarios finished so far are listed). One line is printed per "
    "scenario as it finishes."
)


def check(
    paths: Annotated[
        list[str], typer.Argument(metavar="PATH...", help="Scenario files, folders or globs.")
    ],
    workers: Annotated[
        int | None,
        typer.Option(
            "--workers", "-j", min=1, help="Local worker processes (default: the core count)."
        ),
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option("--scheduler", metavar="tcp://HOST:PORT", help="Run on this Dask cluster."),
    ] = None,
    debug: Annotated[bool, typer.Option("--debug", help="Show the traceback of an error.")] = False,
) -> None:
    """Run the scenarios' checks (CI gate)."""
    raise typer.Exit(guarded("inins check", debug, lambda: _check(paths, workers, scheduler)))


check.__doc__ = _HELP


def _check(paths, workers, scheduler) -> int:
    from inins.sweep.check import CheckOutcome, collect, failures
    from inins.sweep.executors import DaskExecutor, LocalExecutor, default_workers

    targets, skipped = collect(paths)
    command = targets[0].command if len({t.command for t in targets}) == 1 else None
    if scheduler:
        executor = DaskExecutor(scheduler, command)
    else:
        executor = LocalExecutor(min(workers or default_workers(), len(targets)), command)
    typer.echo(f"checking {len(targets)} scenarios")
    records = {}
    try:
        _run(targets, executor, records)
    except KeyboardInterrupt:
        done = [CheckOutcome(targets[i], r) for i, r in sorted(records.items())]
        passed = sum(o.passed for o in done)
        for line in failures(done):
            echo_err(line)
        echo_err(
            f"inins check: interrupted; {len(done)} of {len(targets)} scenarios finished "
            f"({passed} passed), listed above; the others did not run to the end"
        )
        return EXIT_INTERRUPTED
    outcomes = [CheckOutcome(t, records[i]) for i, t in enumerate(targets)]
    if skipped:
        typer.echo(
            f"skipped {len(skipped)} file(s) without checks: "
            + ", ".join(str(Path(p)) for p in skipped)
        )
    lines = failures(outcomes)
    for line in lines:
        typer.echo(line, err=True)
    passed = sum(o.passed for o in outcomes)
    typer.echo(f"{passed} of {len(outcomes)} scenarios passed")
    errors = [o.record for o in outcomes if o.record["status"] == "error"]
    if any(r["error_type"] not in ("InputError", "ValidationError") for r in errors):
        return EXIT_INTERNAL
    if errors:
        return EXIT_BAD_INPUT
    return EXIT_OK if not lines else EXIT_CHECK_FAILED


def _run(targets, executor, records) -> None:
    """Run every target on ``executor``; print one line per scenario as it finishes
    (``records``: index -> worker record, filled as they arrive)."""
    from inins.sweep.check import check_records

    with executor as ex:
        try:
            for record in check_records(targets, ex):
                records[record["index"]] = record
                _line(targets[record["index"]], record, len(records), len(targets))
        except KeyboardInterrupt:
            _stop_workers(ex)
            raise


def _line(target, record, done, total) -> None:
    n = len(record["checks"])
    ok = sum(passed for _, passed in record["checks"])
    status = record["status"]
    verdict = "PASS" if status == "passed" else ("ERROR" if status == "error" else "FAIL")
    typer.echo(
        f"[{done}/{total}] {verdict:5s} {target.path} ({target.command}, {ok}/{n} checks, "
        f"{record['run_s']:.1f} s)"
    )


def _stop_workers(executor) -> None:
    """End the local worker processes at once (they ignore Ctrl-C and would finish their
    scenario first): an interrupt must end the check promptly."""
    terminate = getattr(executor, "terminate", None)
    if terminate is not None:
        terminate()
        return
    pool = getattr(executor, "pool", None)
    for process in list(getattr(pool, "_processes", {}).values() if pool else ()):
        try:
            process.terminate()
        except (OSError, AttributeError):
            pass
