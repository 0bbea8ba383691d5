"""The CLI side of a command run: parse the options, call
:func:`inins.commands.execute.execute`, print, choose the exit code.

Exit codes: 0 done, 1 a check failed, 2 bad input (:class:`InputError`, and
pydantic or YAML errors that slip through; also an output folder that cannot take
the results: unwritable, full disk, :class:`~inins.exceptions.OutputError`; and a
run too large for the machine), 3 internal error (a bug), 4 command not available
in this version, 130 interrupted (nothing written). Messages are one line (plus
listed extra problems) on stderr; tracebacks only with ``--debug``.
"""

import sys
import time
from pathlib import Path
from typing import Annotated

from inins.commands import CommandUnavailable
from inins.exceptions import InputError

EXIT_OK, EXIT_CHECK_FAILED, EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_UNAVAILABLE = 0, 1, 2, 3, 4
EXIT_INTERRUPTED = 130
DEFAULT_OUTDIR = Path("out")
"""Parent of every command's default output folder: ``out/<command>``."""
OUTDIR_HELP = "Output directory (created if missing); default out/{name}."


def output_folder(outdir, name) -> Path:
    """The output folder given with ``-o`` (a string), or the default ``out/<name>``;
    an empty ``-o ''`` is bad input (it would mean the current directory)."""
    if outdir is None:
        return DEFAULT_OUTDIR / name
    if not str(outdir).strip():
        raise InputError(
            "an empty output folder was given; name one (-o . for the current folder)",
            key="--outdir",
        )
    return Path(outdir)


def make_command(spec):
    """The Typer command function of a registered command."""
    import typer

    def command(
        scenario: Annotated[
            Path | None,
            typer.Argument(
                metavar="SCENARIO.yaml",
                show_default=False,
                help="Scenario file; without it the shipped default scenario runs.",
            ),
        ] = None,
        outdir: Annotated[
            str | None,
            typer.Option(
                "--outdir",
                "-o",
                metavar="OUTDIR",
                show_default=False,
                help=OUTDIR_HELP.format(name=spec.name),
            ),
        ] = None,
        overrides: Annotated[
            list[str] | None,
            typer.Option(
                "--set",
                metavar="KEY.PATH=VALUE",
                show_default=False,
                help="Override a scenario key (repeatable), e.g. --set imu.gyro.bias_dph=[1,0,0] "
                "or --set motion.3.duration_s=60. The value is YAML.",
            ),
        ] = None,
        seed: Annotated[
            int | None,
            typer.Option(
                "--seed",
                metavar="N",
                show_default=False,
                help="Random seed, 0 to 2**63-1; wins over the scenario's seed (default 0).",
            ),
        ] = None,
        debug: Annotated[
            bool, typer.Option("--debug", help="Show the traceback of an error.")
        ] = False,
        plot: Annotated[
            bool,
            typer.Option(
                "--plot", help="Also write PNG figures (needs the plot extra: matplotlib)."
            ),
        ] = False,
        force: Annotated[
            bool,
            typer.Option(
                "--force",
                help="Run even if the estimated samples, output size or memory exceed "
                "the limits (free disk, available memory, 1e9 samples).",
            ),
        ] = False,
    ) -> None:
        raise typer.Exit(
            run_command(spec, scenario, outdir, overrides or [], seed, debug, plot, force)
        )

    command.__doc__ = spec.full_help()
    command.__name__ = spec.name.replace("-", "_")
    return command


def run_command(
    spec, scenario, outdir, overrides, seed, debug=False, plot=False, force=False
) -> int:
    """Run one command end to end; return the exit code (never raises)."""
    return guarded(
        f"inins {spec.name}",
        debug,
        lambda: _run(
            spec, scenario, output_folder(outdir, spec.name), list(overrides), seed, plot, force
        ),
    )


def guarded(label: str, debug: bool, body) -> int:
    """Call ``body()`` and turn every exception into a message and exit code."""
    try:
        return body()
    except KeyboardInterrupt:
        echo_err(f"{label}: interrupted; no output written (earlier results are untouched)")
        return EXIT_INTERRUPTED
    except CommandUnavailable as exc:
        echo_err(str(exc))
        return EXIT_UNAVAILABLE
    except MemoryError:
        echo_err(
            f"{label}: error: out of memory; the run is too large for this machine "
            "(shorten it, lower the sample rate, or stream it with simulate-table)"
        )
        return EXIT_BAD_INPUT
    except Exception as exc:
        if debug:
            import traceback

            traceback.print_exception(exc, file=sys.stderr)
        message = input_message(exc)
        if message is not None:
            echo_err(f"{label}: error: {message}")
            return EXIT_BAD_INPUT
        hint = "" if debug else " (run with --debug for the traceback)"
        echo_err(f"{label}: internal error: {type(exc).__name__}: {exc}{hint}")
        return EXIT_INTERNAL


def input_message(exc) -> str | None:
    """The message of a bad-input exception, or None if ``exc`` is something else."""
    if isinstance(exc, InputError):
        return str(exc)
    pydantic = sys.modules.get("pydantic")
    if pydantic is not None and isinstance(exc, pydantic.ValidationError):
        errors = exc.errors()
        first = errors[0]
        where = ".".join(str(p) for p in first["loc"]) or exc.title
        more = f" (and {len(errors) - 1} more problems)" if len(errors) > 1 else ""
        return f"{where}: {first['msg']}{more}"
    yaml = sys.modules.get("yaml")
    if yaml is not None and isinstance(exc, yaml.YAMLError):
        return f"invalid YAML: {' '.join(str(exc).split())}"
    return None


def echo_err(message: str) -> None:
    """One plain message on stderr (no markup, no wrapping), as ``typer.echo(message,
    err=True)`` writes it (without loading Typer)."""
    stream = sys.stderr
    if stream is None:
        return
    stream.write(f"{message}\n")
    stream.flush()


def _run(spec, scenario, outdir, overrides, seed, plot=False, force=False) -> int:
    from inins.cli._display import ProgressBar, print_outcome
    from inins.commands.execute import execute
    from inins.commands.warmup import COMPILE_S, CompileNotice
    from inins.core import jit

    start = time.perf_counter()
    notice = jit.on_compile(CompileNotice(f"inins {spec.name}", echo_err, COMPILE_S.get(spec.name)))
    try:
        with ProgressBar(spec.name) as bar:
            done = execute(
                spec, scenario, overrides, seed, outdir, figures=plot, progress=bar, force=force
            )
    finally:
        jit.remove_compile_listener(notice)
        notice.close()
    print_outcome(done.summary, done.paths, time.perf_counter() - start)
    if done.interrupted is not None:
        echo_err(
            f"inins {spec.name}: an interrupt arrived while the finished outputs were "
            "being renamed; all of them are complete and in place"
        )
    return EXIT_OK if done.summary["passed"] else EXIT_CHECK_FAILED
