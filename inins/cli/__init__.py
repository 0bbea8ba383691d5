"""The ``inins`` command line: one Typer app, one module per command.

Usage::

    inins CMD [SCENARIO.yaml] [-o OUTDIR] [--set KEY.PATH=VALUE ...] [--seed N] [--debug]
    inins schema CMD
    inins show FILE.h5

A command module (``inins/cli/<command_with_underscores>.py``)
===============================================================
A command is a row of :data:`inins.cli._registry.COMMANDS` (name, module,
help, shipped default scenario ``configs/<name>/default.yaml``) and a module
that provides exactly two names:

``SCENARIO_MODEL``
    The scenario's pydantic model, a subclass of
    :class:`inins.io.scenario.ScenarioModel` (it brings ``seed`` and
    ``checks``).
``run``
    A plain function, either ``run(model, seed) -> CommandResult`` or, for
    output too large for memory, ``run(model, seed, sink) -> CommandResult``
    which also streams series into ``sink`` (a
    :class:`inins.results.SeriesSink` writing into CMD.h5 on a background
    thread). ``seed`` is the seed to use (``--seed`` > scenario > 0), not
    necessarily ``model.seed``. ``run`` raises
    :class:`inins.exceptions.InputError` for bad input and never prints or exits.

The module may import anything at its top: it is imported only when the
command runs (or ``inins schema`` asks for its model). A placeholder sets
``SCENARIO_MODEL = None``; the command then says it is not implemented yet
and exits 2. Everything else (loading and validating the scenario, seeds,
writing CMD.h5/CMD.txt/summary.json atomically, checks, terminal summary,
exit codes) is done once in :mod:`inins.cli._runner`.

Keep this package cheap to import: ``inins --help`` must not load numpy,
scipy, numba, h5py or pydantic.
"""

from typing import Annotated

import typer

import inins
from inins.cli._registry import COMMANDS
from inins.cli._runner import make_command
from inins.cli.schema import make_schema_command
from inins.cli.show import show

_HELP = (
    "Calibration and analysis of strapdown inertial navigation systems.\n\n"
    "Each command reads a YAML scenario (or runs its shipped default), writes "
    "OUTDIR/CMD.h5, OUTDIR/CMD.txt and OUTDIR/summary.json, and exits 0 (done), "
    "1 (a check failed) or 2 (bad input)."
)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"inins {inins.__version__}")
        raise typer.Exit(0)


def make_app(commands=COMMANDS) -> typer.Typer:
    """The Typer app for a command registry (tests build one with a fake command)."""
    app = typer.Typer(
        name="inins", help=_HELP, no_args_is_help=True, add_completion=False,
        pretty_exceptions_enable=False, context_settings={"help_option_names": ["-h", "--help"]},
    )

    @app.callback()
    def _root(
        version: Annotated[bool, typer.Option(
            "--version", is_eager=True, callback=_version, help="Print the version and exit.")]
        = False,
    ) -> None:
        pass

    for spec in commands:
        app.command(spec.name, help=spec.full_help(), short_help=spec.help)(make_command(spec))
    app.command("schema")(make_schema_command(commands))
    app.command("show")(show)
    return app


app = make_app()


def main() -> None:
    """Console-script entry point: SIGTERM is handled like Ctrl-C (no partial files)."""
    import signal

    def _terminate(signum, frame):
        raise KeyboardInterrupt

    if hasattr(signal, "SIGTERM"):
        signal.signal(signal.SIGTERM, _terminate)
    app(prog_name="inins")
