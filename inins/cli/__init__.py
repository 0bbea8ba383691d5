"""The ``inins`` command line: one Typer app; it parses arguments and prints.

Usage::

    inins CMD [SCENARIO.yaml] [-o OUTDIR] [--set KEY.PATH=VALUE ...] [--seed N] [--debug]
    inins schema CMD
    inins show FILE.h5

The commands are the table :data:`inins.commands.COMMANDS`; each runs through
:func:`inins.commands.execute.execute` (scenario, seed, atomic outputs, checks),
called by :mod:`inins.cli._runner`, which turns exceptions into messages and exit
codes. Keep this package cheap to import: ``inins --help`` must not load numpy,
scipy, numba, h5py or pydantic.
"""

import io
import sys
from typing import Annotated

import typer

import inins
from inins.cli._runner import make_command
from inins.cli.check import check
from inins.cli.schema import make_schema_command
from inins.cli.show import show
from inins.cli.sweep import sweep
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
    return app


app = make_app()


def main() -> None:
    """Console-script entry point: SIGTERM and SIGHUP are handled like Ctrl-C (no partial
    files); a closed standard output (``inins check configs | head -1``) is not an error:
    the run goes on silently and ends with its own exit code."""
    import gc
    import os
    import signal

    # small matrices only: a threaded BLAS adds hand-over cost (set before numpy loads)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

    def _terminate(signum, frame):
        raise KeyboardInterrupt

    for name in ("SIGTERM", "SIGHUP"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), _terminate)
    quiet_closed_stdout()
    try:
        app(prog_name="inins")
    except SystemExit as exc:
        _exit_past_failed_hdf5(exc.code)
        raise
    finally:
        # The run is over and its files are closed. Python's last garbage collection
        # would walk every object the imports made (about 0.1 s, a fifth of a short
        # run); frozen objects are left to the operating system instead.
        gc.freeze()


class _QuietPipe(io.FileIO):
    """Standard output that, once its reader has gone (EPIPE), sends the rest of the
    output to the null device instead of raising in the middle of a run."""

    def write(self, data):
        try:
            return super().write(data)
        except BrokenPipeError:
            import os

            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, self.fileno())
            os.close(null)
            return len(data)


def quiet_closed_stdout() -> None:
    """Replace ``sys.stdout`` by a text stream over :class:`_QuietPipe` (same encoding and
    buffering); nothing changes for a terminal except the closed-pipe case."""
    stdout = sys.stdout
    try:
        fd = stdout.fileno()
    except (AttributeError, OSError, ValueError):
        return  # not a real file (captured by a test runner)
    stdout.flush()
    tty = stdout.isatty()
    raw = _QuietPipe(fd, "w", closefd=False)
    sys.stdout = io.TextIOWrapper(
        io.BufferedWriter(raw),
        encoding=stdout.encoding,
        errors=stdout.errors,
        line_buffering=tty,
    )


def _exit_past_failed_hdf5(code) -> None:
    """End the process at once if HDF5 was left with a file it failed to write (a disk
    that filled up under it): its own clean-up at exit would crash on that file."""
    import os

    hdf5 = sys.modules.get("inins.io.hdf5")
    if hdf5 is not None and hdf5._abandoned:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code if isinstance(code, int) else 1)
