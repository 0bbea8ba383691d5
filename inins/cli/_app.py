"""The Typer app of the ``inins`` command line (:mod:`inins.cli`): every command, with
its help. Loaded when a command line is parsed, and by tests (``from inins.cli import
app``).
"""

from typing import Annotated

import typer

import inins
from inins.cli._runner import make_command
from inins.cli.check import check
from inins.cli.schema import make_schema_command
from inins.cli.show import show
from inins.cli.sweep import sweep
from inins.cli.warmup import warmup
from inins.commands import COMMANDS

_HELP = (
    "Calibration and analysis of strapdown inertial navigation systems.\n\n"
    "Each command reads a YAML scenario (or runs its shipped default), writes "
    "OUTDIR/CMD.h5, OUTDIR/CMD.txt and OUTDIR/summary.json.\n\n"
    "Exit codes: 0 done, 1 a check failed, 2 bad input (also an output folder that "
    "cannot take the results, a full disk, or a run too large for the machine: see "
    "--force), 3 internal error (a bug: please report it with --debug), 4 command not "
    "available in this version, 130 interrupted (nothing written)."
)


def _no_flag_placeholders() -> None:
    """Typer's help shows an on/off flag with a ``<bool>`` placeholder as if it took a
    value: show flags bare, as ``--plot``, ``--help``."""
    from typer.core import TyperOption

    shown = TyperOption.display_type_rich
    if getattr(shown, "_inins_flags_bare", False):
        return

    def display_type_rich(self, ctx):
        return None if self.is_flag else shown(self, ctx)

    display_type_rich._inins_flags_bare = True
    TyperOption.display_type_rich = display_type_rich


_no_flag_placeholders()


def _version(value: bool) -> None:
    if value:
        typer.echo(f"inins {inins.__version__}")
        raise typer.Exit(0)


def make_app(commands=COMMANDS) -> typer.Typer:
    """The Typer app for a command registry (tests build one with a fake command)."""
    app = typer.Typer(
        name="inins",
        help=_HELP,
        no_args_is_help=True,
        add_completion=False,
        pretty_exceptions_enable=False,
        context_settings={"help_option_names": ["-h", "--help"]},
    )

    @app.callback()
    def _root(
        version: Annotated[
            bool,
            typer.Option(
                "--version", is_eager=True, callback=_version, help="Print the version and exit."
            ),
        ] = False,
    ) -> None:
        pass

    for spec in commands:
        short = spec.help if spec.available else f"(not yet available) {spec.help}"
        app.command(spec.name, help=spec.full_help(), short_help=short)(make_command(spec))
    app.command("schema")(make_schema_command(commands))
    app.command("show")(show)
    app.command("sweep")(sweep)
    app.command("check")(check)
    app.command("warmup")(warmup)
    return app


app = make_app()
