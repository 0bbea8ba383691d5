"""``inins sweep SWEEP.yaml -o OUTDIR``: run a sweep, show progress, print aggregates."""

import os
from pathlib import Path
from typing import Annotated

import typer

from inins.cli._runner import (
    EXIT_CHECK_FAILED,
    EXIT_INTERRUPTED,
    EXIT_OK,
    OUTDIR_HELP,
    echo_err,
    guarded,
    output_folder,
)

MAX_LISTED = 10
MAX_DEFAULT_FIGURES = 8
"""``--plot`` without ``aggregate.results`` draws at most this many varying results."""

_HELP = (
    "Run a command over a grid of scenario keys, zipped axes and Monte Carlo seeds "
    "(spec §8). Each point runs as 'inins CMD BASE --set KEY=VALUE ... --seed N' would. "
    "Writes OUTDIR/sweep.csv and OUTDIR/sweep.h5 (one row per point: axes, seed, status, "
    "error, run time, results, truth, checks), OUTDIR/aggregates.csv and OUTDIR/sweep.txt. "
    "Rerunning resumes: finished points are skipped. Exit codes: 0 every point passed, "
    "1 a point failed a check or raised, 2 bad input, 3 internal error, 130 interrupted "
    "(the table holds the finished points)."
)


def sweep(
    sweep_file: Annotated[Path, typer.Argument(metavar="SWEEP.yaml", help="The sweep file.")],
    outdir: Annotated[
        str | None,
        typer.Option(
            "--outdir",
            "-o",
            metavar="OUTDIR",
            show_default=False,
            help=OUTDIR_HELP.format(name="sweep"),
        ),
    ] = None,
    workers: Annotated[
        int | None,
        typer.Option(
            "--workers", "-j", min=1, help="Local worker processes (default: the core count)."
        ),
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler", metavar="tcp://HOST:PORT", help="Run on this Dask cluster instead."
        ),
    ] = None,
    keep_runs: Annotated[
        bool,
        typer.Option("--keep-runs", help="Also write every point's outputs to OUTDIR/runs/ID/."),
    ] = False,
    restart: Annotated[
        bool,
        typer.Option("--restart", help="Discard an earlier sweep in OUTDIR instead of resuming."),
    ] = False,
    retry_errors: Annotated[
        bool, typer.Option("--retry-errors", help="On resume, rerun the points that raised.")
    ] = False,
    max_points: Annotated[
        int, typer.Option("--max-points", min=1, help="Refuse a sweep with more points.")
    ] = 100_000,
    overrides: Annotated[
        list[str] | None,
        typer.Option(
            "--set",
            metavar="KEY.PATH=VALUE",
            show_default=False,
            help="Override a scenario key of every point (repeatable), after the file's set:.",
        ),
    ] = None,
    seed: Annotated[
        int | None,
        typer.Option(
            "--seed",
            metavar="N",
            show_default=False,
            help="Random seed of every point (a sweep without seeds:).",
        ),
    ] = None,
    plot: Annotated[
        bool,
        typer.Option(
            "--plot",
            help="Also write PNG figures: each result of aggregate.results (default: the "
            f"first {MAX_DEFAULT_FIGURES} results that vary) against the swept keys "
            "(needs the plot extra: matplotlib).",
        ),
    ] = False,
    plot_result: Annotated[
        list[str] | None,
        typer.Option(
            "--plot-result",
            metavar="RESULT",
            help="Draw RESULT against the swept keys (repeatable): a line or a heat map.",
        ),
    ] = None,
    against: Annotated[
        list[str] | None,
        typer.Option("--against", metavar="KEY", help="Swept key(s) for the figures (one or two)."),
    ] = None,
    debug: Annotated[bool, typer.Option("--debug", help="Show the traceback of an error.")] = False,
) -> None:
    """Run a sweep (grids, zipped axes, Monte Carlo seeds) locally or on a Dask cluster."""
    raise typer.Exit(
        guarded(
            "inins sweep",
            debug,
            lambda: _sweep(
                sweep_file,
                output_folder(outdir, "sweep"),
                workers,
                scheduler,
                keep_runs,
                restart,
                retry_errors,
                max_points,
                _Figures(plot, plot_result or [], against or []),
                overrides or [],
                seed,
            ),
        )
    )


sweep.__doc__ = _HELP


class _Figures:
    """What ``--plot``, ``--plot-result`` and ``--against`` ask for."""

    def __init__(self, shipped, named, against):
        self.shipped, self.named, self.against = shipped, list(named), list(against)

    def __bool__(self):
        return bool(self.shipped or self.named)

    def results(self, plan, table):
        """The results to draw: the named ones, and with ``--plot`` aggregate.results
        (or the first results that vary between points)."""
        import numpy as np

        chosen = list(self.named)
        if self.shipped:
            listed = plan.aggregate.results
            if not listed:
                listed = []
                for name in table.result_names:
                    y = np.asarray(table.result(name), float)
                    y = y[np.isfinite(y)]
                    if y.size > 1 and np.ptp(y) > 0:
                        listed.append(name)
                listed = listed[:MAX_DEFAULT_FIGURES]
            chosen += [name for name in listed if name not in chosen]
        return chosen


def _sweep(
    path,
    outdir,
    workers,
    scheduler,
    keep_runs,
    restart,
    retry,
    max_points,
    figures,
    overrides=(),
    seed=None,
):
    from inins.commands.execute import check_owner
    from inins.sweep.engine import run_sweep
    from inins.sweep.executors import DaskExecutor, LocalExecutor, default_workers
    from inins.sweep.plan import load_sweep
    from inins.sweep.plot import check_plot_request, plot_result

    if not scheduler:  # the workers' server imports while the sweep is loaded
        from inins.sweep.executors import start_server

        start_server(_command_of(path))
    plan = load_sweep(path, max_points, overrides, seed)
    check_owner(outdir, "sweep")
    keys = check_plot_request(plan, figures.named, figures.against) if figures else ()
    if scheduler:
        executor = DaskExecutor(scheduler, plan.command)
    else:
        executor = LocalExecutor(workers or default_workers(), plan.command)
    try:
        with _Progress(plan.size) as bar:
            outcome = run_sweep(plan, outdir, executor, keep_runs, restart, retry, progress=bar)
    except KeyboardInterrupt:
        echo_err(
            f"inins sweep: interrupted; the finished points are in {outdir}/sweep.csv; "
            "run the same command again to resume"
        )
        return EXIT_INTERRUPTED
    paths = list(outcome.paths)
    for result in figures.results(plan, outcome.table) if figures else ():
        png = Path(outdir) / f"plot-{result}.png"
        plot_result(outcome.table, result, keys, png)
        paths.append(png)
    _print(outcome, paths)
    failed = sum(r["status"] != "passed" for r in outcome.table.records)
    return EXIT_OK if failed == 0 else EXIT_CHECK_FAILED


def _command_of(path):
    """The ``command:`` of a sweep file, or None (errors are left to load_sweep)."""
    try:
        import yaml

        content = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
        command = content.get("command") if isinstance(content, dict) else None
        return command if isinstance(command, str) else None
    except (OSError, ValueError, yaml.YAMLError):
        return None


class _Progress:
    """A rich progress bar with ETA and the count of points that raised."""

    def __init__(self, total):
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self.progress = Progress(
            TextColumn("sweep"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[errors]} errors"),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            transient=True,
            disable=not os.isatty(2),
        )
        self.task = self.progress.add_task("sweep", total=total, errors=0)

    def __enter__(self):
        self.progress.__enter__()
        return self

    def __exit__(self, *exc):
        self.progress.__exit__(*exc)

    def __call__(self, done, total, errors):
        self.progress.update(self.task, completed=done, total=total, errors=errors)


def _print(outcome, paths) -> None:
    from inins.sweep.aggregate import format_aggregates

    counts = (
        f"{outcome.ran} run, {outcome.skipped} already finished, {outcome.errors} raised; "
        f"{len(outcome.table.records)} of {outcome.planned} points in the table "
        f"({outcome.wall_s:.1f} s)"
    )
    typer.echo(f"inins sweep: {counts}")
    typer.echo(format_aggregates(outcome.aggregates, overall_only=True))
    typer.echo("(statistics per value of each swept key: sweep.txt, aggregates.csv)")
    raised = [r for r in outcome.table.records if r["status"] == "error"]
    for record in raised[:MAX_LISTED]:
        typer.echo(f"point {record['index']} raised: {record['error']}", err=True)
    if len(raised) > MAX_LISTED:
        typer.echo(f"... and {len(raised) - MAX_LISTED} more (column error of sweep.csv)", err=True)
    typer.echo("wrote " + ", ".join(str(p) for p in paths))
