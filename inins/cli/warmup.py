"""``inins warmup [COMMAND...]``: compile the numerical kernels ahead of the first run."""

from typing import Annotated

import typer

from inins.cli._runner import echo_err, guarded


def warmup(
    commands: Annotated[
        list[str] | None,
        typer.Argument(
            metavar="COMMAND",
            help="Commands whose kernels to compile (default: every command).",
            show_default=False,
        ),
    ] = None,
    jobs: Annotated[
        int | None,
        typer.Option(
            "--jobs",
            "-j",
            min=1,
            help="Processes compiling side by side (default: the cores, at most 4).",
            show_default=False,
        ),
    ] = None,
    debug: Annotated[bool, typer.Option("--debug", help="Show the traceback of an error.")] = False,
) -> None:
    """Compile the numerical kernels of COMMANDs (all by default) for this machine.

    A command compiles the kernels it needs on its first run after an install, an
    upgrade or an edit (it says so, with the time it takes); later runs load them
    from numba's on-disk cache. Run this once ahead, e.g. when building a lab
    machine or a CI image, so that no run waits for a compile. Short runs of shipped
    scenarios do the compiling; nothing is written but the cache.
    """
    raise typer.Exit(guarded("inins warmup", debug, lambda: _warmup(commands or [], jobs)))


def _warmup(commands, jobs) -> int:
    import os

    from inins.commands import warmup
    from inins.exceptions import InputError

    unknown = [c for c in commands if c not in warmup.RUNS]
    if unknown:
        raise InputError(
            f"no command {unknown[0]!r} to warm up (commands: {', '.join(warmup.RUNS)})"
        )
    warmup.main(commands, echo=echo_err, jobs=jobs or min(os.cpu_count() or 1, 4))
    return 0
