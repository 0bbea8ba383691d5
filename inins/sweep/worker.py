"""One sweep point, run in a worker process: :func:`inins.commands.execute.execute`,
the function behind ``inins CMD``, with the point's overrides and seed.

Everything here is a plain module-level function of plain arguments, so a process
pool or a Dask worker can pickle it. A worker process imports the command module
once (:func:`warm_up`) and keeps its compiled kernels for every later point.
"""

import time
from dataclasses import dataclass

STATUS_PASSED = "passed"
STATUS_FAILED = "check-failed"
STATUS_ERROR = "error"


@dataclass(frozen=True)
class PointTask:
    """What a worker needs to run one point (picklable).

    Attributes
    ----------
    key : str
        :attr:`inins.sweep.plan.Point.key`.
    index : int
    command : str
    base : str or None
        Base scenario path (None: the shipped default).
    overrides : tuple of str
    seed : int or None
    outdir : str or None
        Where to write the point's outputs (``--keep-runs``); None writes nothing.
    """

    key: str
    index: int
    command: str
    base: str | None
    overrides: tuple
    seed: int | None
    outdir: str | None = None


def warm_up(
    command: str | None = None,
    ignore_sigint: bool = True,
    parent: int | None = None,
) -> None:
    """Worker initialiser: leave Ctrl-C to the parent, load numba, import the command.

    ``parent``: the pid of the sweep process; the worker ends itself when that
    process is gone (:func:`exit_with_parent`), so a sweep killed outright
    (``kill -9``) leaves no worker behind. numba is loaded once per worker, and its
    kernels from the on-disk cache on their first call (:mod:`inins.core.jit`), so
    the runs of a sweep pay neither again.
    """
    import signal

    from inins.core import jit

    if ignore_sigint:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    if parent is not None:
        exit_with_parent(parent)
    jit.activate()
    if command is not None:
        from inins.commands import find_command, load_command

        load_command(find_command(command))


def exit_with_parent(parent: int, every_s: float = 0.25) -> None:
    """End this process (``os._exit``) soon after process ``parent`` ends.

    A pool worker is a child of the start method's server process, not of the sweep:
    on Linux the kernel sends it SIGKILL when that server exits (``PR_SET_PDEATHSIG``;
    the server exits when the sweep does), and a daemon thread checks every
    ``every_s`` that the sweep process still runs (not a zombie) and that this
    process was not handed to another parent.
    """
    import os
    import signal
    import threading

    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the thread alone
        pass
    first_parent = os.getppid()

    def watch():
        while _alive(parent) and os.getppid() == first_parent:
            time.sleep(every_s)
        os._exit(1)

    threading.Thread(target=watch, name="inins-parent-watch", daemon=True).start()


def _alive(pid: int) -> bool:
    """True while process ``pid`` exists and is not a zombie."""
    import os

    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            return f.read().rsplit(b")", 1)[1].split()[0] != b"Z"
    except FileNotFoundError:
        return False
    except OSError:  # no /proc: ask the kernel
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            return True
        return True


def run_point(task: PointTask) -> dict:
    """Run one point; never raises (an exception is recorded in the returned record).

    Returns
    -------
    dict
        ``key``, ``index``, ``seed`` (the seed used), ``status`` (passed,
        check-failed, error), ``error`` (message, "" when none), ``error_type``,
        ``error_key`` (key path of a bad-input error), ``results``, ``truth``
        (flat name -> number or None), ``checks`` (list of [expression, passed]),
        ``run_s`` (wall time of the run in the worker, s), ``cpu_s`` (CPU time of the
        worker process during the run, s).
    """
    from inins.commands import find_command
    from inins.commands.execute import execute
    from inins.exceptions import InputError

    start, cpu_start = time.perf_counter(), time.process_time()
    record = {"key": task.key, "index": task.index, "seed": task.seed}
    try:
        done = execute(
            find_command(task.command), task.base, task.overrides, task.seed, task.outdir
        )
    except Exception as exc:
        record.update(
            status=STATUS_ERROR,
            error=str(exc) or type(exc).__name__,
            error_type=type(exc).__name__,
            error_key=getattr(exc, "key", None) if isinstance(exc, InputError) else None,
            results={},
            truth={},
            checks=[],
        )
    else:
        summary = done.summary
        record.update(
            seed=summary["seed"],
            status=STATUS_PASSED if summary["passed"] else STATUS_FAILED,
            error="",
            error_type="",
            error_key=None,
            results=summary["results"],
            truth=summary["truth"],
            checks=[[c["name"], bool(c["passed"])] for c in summary["checks"]],
        )
    record["run_s"] = time.perf_counter() - start
    record["cpu_s"] = time.process_time() - cpu_start
    return record


def run_points(tasks) -> list:
    """Run a batch of points in order (one Dask task for several short points)."""
    return [run_point(task) for task in tasks]


def is_check_name_error(record: dict) -> bool:
    """True if the point failed because a check names an unknown result (bad input
    shared by every point: the sweep stops)."""
    key = record.get("error_key") or ""
    return record["status"] == STATUS_ERROR and key.startswith("checks[")
