"""Write files under a temporary name; rename them only when complete.

A file ``OUT/name`` is written as ``OUT/.name.partial-<pid>`` (same directory,
so the rename is atomic on POSIX and Windows) and moved over ``OUT/name`` with
:func:`os.replace` on commit. On failure or interrupt the temporary file is
removed and an earlier ``OUT/name`` is left as it was. A run killed outright
(SIGKILL, power loss) can leave a hidden ``.partial-<pid>`` file, never a
truncated file under the final name; :func:`remove_stale_partials` deletes
those whose process is gone (every run calls it on its output folder).

:class:`AtomicGroup` commits several files in a stated order after all of
them are complete (the runner puts ``summary.json`` last, so its presence
marks a finished run). For the renames it

- holds SIGINT/SIGTERM: a signal that arrives then is recorded in
  :attr:`AtomicGroup.interrupted` and *not* re-raised, since the outputs are
  complete by the time it could act (the caller says so and finishes);
- holds an exclusive ``flock`` on the output folder itself (no lock file), so
  concurrent runs into one folder commit one after the other and the folder
  always holds one run's complete set, never a mix;
- refuses to commit at all once a termination was requested
  (:func:`request_stop`): the ``KeyboardInterrupt`` a signal handler raises is lost
  when it lands in a C callback (numba's compiler calls back into Python), and the
  run would otherwise finish and write its files after SIGTERM.
"""

import contextlib
import os
import re
import signal
import threading
from pathlib import Path

try:
    import fcntl
except ImportError:  # Windows: no folder lock
    fcntl = None

_PARTIAL = re.compile(r"^\..+\.partial-(\d+)$")
_before_rename = None
"""Test hook: ``_before_rename(path)`` is called before each rename of a group commit
(a test sends a signal or sleeps there to hit the window)."""


_stop_requested = None
"""The signal of a termination request (:func:`request_stop`), else None."""


def request_stop(signum: int) -> None:
    """Record that the process was asked to stop (signal ``signum``); no group commits
    after this. The CLI's signal handlers call it before raising KeyboardInterrupt."""
    global _stop_requested
    _stop_requested = signum


def partial_path(path) -> Path:
    """Temporary name of ``path``: ``.NAME.partial-<pid>`` in the same directory."""
    path = Path(path)
    return path.with_name(f".{path.name}.partial-{os.getpid()}")


class AtomicFile:
    """One output file written under a temporary name.

    Write to :attr:`tmp`; :meth:`commit` renames it to :attr:`path`,
    :meth:`discard` removes it. As a context manager it commits on success and
    discards on any exception (KeyboardInterrupt included).

    Parameters
    ----------
    path : str or Path
        Final name.
    durable : bool
        fsync the file before the rename, so a crash right after the commit
        cannot leave an empty file under the final name.
    """

    def __init__(self, path, durable: bool = True):
        self.path = Path(path)
        self.tmp = partial_path(self.path)
        self.durable = durable

    def commit(self) -> None:
        """Rename the finished temporary file to the final name."""
        if self.durable:
            fd = os.open(self.tmp, os.O_RDWR)  # write access: fsync needs it on Windows
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        os.replace(self.tmp, self.path)

    def discard(self) -> None:
        """Remove the temporary file if it exists."""
        with contextlib.suppress(FileNotFoundError):
            self.tmp.unlink()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.commit()
        else:
            self.discard()
        return False


class AtomicGroup:
    """Several output files committed together, in order, once all are complete.

    Parameters
    ----------
    directory : str or Path
        Where the files go (must exist).
    names : sequence of str
        File names in commit order.
    stale : iterable of str
        Files of an earlier run that this one does not write (a figure not asked for
        this time): removed by the commit, before the renames, so that the folder
        holds one run's files only.
    """

    def __init__(self, directory, names, durable: bool = True, stale=()):
        self.directory = Path(directory)
        self.files = {name: AtomicFile(self.directory / name, durable) for name in names}
        self.stale = set(stale) - set(self.files)
        """Names removed by :meth:`commit` (add a file dropped from :attr:`files`)."""
        self.interrupted = None
        """Signal number received (and held) during :meth:`commit`, else None."""

    def __getitem__(self, name) -> AtomicFile:
        return self.files[name]

    def commit(self) -> None:
        """Remove the :attr:`stale` files, then rename every file to its final name, in
        order, with interrupts held and the folder locked; a held interrupt is recorded
        in :attr:`interrupted`.

        Raises
        ------
        KeyboardInterrupt
            A termination was requested earlier (:func:`request_stop`); nothing is
            renamed and the temporary files are removed.
        """
        pending = list(self.files.values())
        with deferred_interrupts(redeliver=False) as received, folder_lock(self.directory):
            try:
                if _stop_requested is not None:
                    raise KeyboardInterrupt
                for name in sorted(self.stale):
                    (self.directory / name).unlink(missing_ok=True)
                while pending:
                    if _before_rename is not None:
                        _before_rename(pending[0].path)
                    pending[0].commit()
                    pending.pop(0)
            finally:
                for f in pending:
                    f.discard()
        self.interrupted = received[0] if received else None

    def discard(self) -> None:
        """Remove every temporary file."""
        for f in self.files.values():
            f.discard()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.commit()
        else:
            self.discard()
        return False


@contextlib.contextmanager
def deferred_interrupts(redeliver: bool = True):
    """Hold SIGINT and SIGTERM until the block ends; yields the list of signals held.

    With ``redeliver`` the first held signal is raised again when the block ends;
    without, the caller reads the list and decides. Only in the main thread
    (elsewhere signals cannot be handled and the block runs unprotected).
    """
    received = []
    if threading.current_thread() is not threading.main_thread():
        yield received
        return
    sigs = [signal.SIGINT] + ([signal.SIGTERM] if hasattr(signal, "SIGTERM") else [])
    old = {sig: signal.signal(sig, lambda signum, frame: received.append(signum)) for sig in sigs}
    try:
        yield received
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
        if received and redeliver:
            signal.raise_signal(received[0])


@contextlib.contextmanager
def folder_lock(directory):
    """Exclusive ``flock`` on ``directory`` itself for the block (waits for other holders).

    Where folder locks are not supported (Windows, some network file systems) the
    block runs unlocked.
    """
    fd = None
    if fcntl is not None:
        try:
            fd = os.open(directory, os.O_RDONLY)
            fcntl.flock(fd, fcntl.LOCK_EX)
        except OSError:
            if fd is not None:
                os.close(fd)
            fd = None
    try:
        yield
    finally:
        if fd is not None:
            fcntl.flock(fd, fcntl.LOCK_UN)
            os.close(fd)


def _process_gone(pid: int) -> bool:
    """True if no process ``pid`` exists (a process of another user counts as alive)."""
    if pid == os.getpid():
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except (PermissionError, OSError):
        return False
    return False


def remove_stale_partials(directory) -> list:
    """Delete ``.NAME.partial-<pid>`` files in ``directory`` whose process is gone.

    A run killed outright (SIGKILL, power loss) leaves its temporary files; a later
    run into the same folder removes them. Files of a live process are kept.

    Returns
    -------
    list of Path
        The files removed.
    """
    removed = []
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return removed
    for entry in entries:
        match = _PARTIAL.match(entry.name)
        if match is None or not entry.is_file(follow_symlinks=False):
            continue
        if _process_gone(int(match.group(1))):
            with contextlib.suppress(OSError):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
    return removed


def write_text_atomic(path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file."""
    with AtomicFile(path) as f:
        f.tmp.write_text(text, encoding="utf-8")
