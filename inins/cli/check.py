"""``inins check PATH...``: the CI gate over scenario files with ``checks:``."""

from pathlib import Path
from typing import Annotated

import typer

from inins.cli._runner import EXIT_BAD_INPUT, EXIT_CHECK_FAILED, EXIT_INTERNAL, EXIT_OK, guarded

_HELP = (
    "Run every scenario with checks: in PATH (files, folders, globs) and report. The "
    "command of a file is its folder's name (configs/<command>/), else the one command "
    "whose scenario accepts it. Files without checks: are skipped. Exit codes: 0 every "
    "check passed, 1 a check failed (listed), 2 bad input (nothing runs if a file is bad; "
    "also a run that stops on bad input), 3 a run raised an internal error."
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
    from inins.sweep.check import collect, failures, run_checks
    from inins.sweep.executors import DaskExecutor, LocalExecutor, default_workers

    targets, skipped = collect(paths)
    command = targets[0].command if len({t.command for t in targets}) == 1 else None
    if scheduler:
        executor = DaskExecutor(scheduler, command)
    else:
        executor = LocalExecutor(min(workers or default_workers(), len(targets)), command)
    outcomes = run_checks(targets, executor)
    for o in outcomes:
        n = len(o.record["checks"])
        ok = sum(passed for _, passed in o.record["checks"])
        verdict = "PASS" if o.passed else ("ERROR" if o.record["status"] == "error" else "FAIL")
        typer.echo(
            f"{verdict:5s} {o.target.path} ({o.target.command}, {ok}/{n} checks, "
            f"{o.record['run_s']:.1f} s)"
        )
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
