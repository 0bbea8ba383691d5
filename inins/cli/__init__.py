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

The Typer app (:mod:`inins.cli._app`) is built when a command line is parsed; a run
printing to a pipe does not load rich (:func:`inins.cli._display.plain_outcome`).
"""

import io
import sys

__all__ = ["app", "main", "make_app"]


def __getattr__(name):
    """``app`` and ``make_app`` (the Typer app, :mod:`inins.cli._app`), loaded on first
    use: ``import inins.cli`` stays cheap."""
    if name in ("app", "make_app"):
        from inins.cli import _app

        globals().update(app=_app.app, make_app=_app.make_app)
        return getattr(_app, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def main() -> None:
    """Console-script entry point.

    SIGTERM and SIGHUP are handled like Ctrl-C (no partial files); each of the three
    is also recorded (:func:`inins.io.atomic.request_stop`), so a run whose
    KeyboardInterrupt was swallowed by a C callback still writes nothing. A closed
    standard output (``inins check configs | head -1``) is not an error: the run goes
    on silently and ends with its own exit code."""
    import gc
    import os
    import signal

    # small matrices only: a threaded BLAS adds hand-over cost (set before numpy loads)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

    import inins.io.atomic  # noqa: F401  (loaded before any signal: the handler imports nothing)

    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), _terminate)
    # inins uses no pydantic plugins: without this, building the scenario models scans
    # every installed package's entry points for them (about 25 ms a run)
    os.environ.setdefault("PYDANTIC_DISABLE_PLUGINS", "1")
    quiet_closed_stdout()
    try:
        _run_argv(sys.argv[1:])
    except SystemExit as exc:
        _exit_past_failed_hdf5(exc.code)
        raise
    finally:
        # The run is over and its files are closed. Python's last garbage collection
        # would walk every object the imports made (about 0.1 s, a fifth of a short
        # run); frozen objects are left to the operating system instead.
        gc.freeze()


def _terminate(signum, frame):
    """Signal handler of a run: records the request
    (:func:`inins.io.atomic.request_stop`) and raises KeyboardInterrupt."""
    from inins.io.atomic import request_stop

    request_stop(signum)
    raise KeyboardInterrupt


def _run_argv(argv) -> None:
    """Run a command line through the Typer app; exits (``SystemExit``) with its code."""
    from inins.cli._app import app

    app(args=list(argv), prog_name="inins")


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
