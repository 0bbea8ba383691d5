"""Write files under a temporary name; rename them only when complete.

A file ``OUT/name`` is written as ``OUT/.name.partial-<pid>`` (same directory,
so the rename is atomic on POSIX and Windows) and moved over ``OUT/name`` with
:func:`os.replace` on commit. On failure or interrupt the temporary file is
removed and an earlier ``OUT/name`` is left as it was. A run killed outright
(SIGKILL, power loss) can leave a hidden ``.partial-<pid>`` file, never a
truncated file under the final name.

:class:`AtomicGroup` commits several files in a stated order after all of
them are complete (the runner puts ``summary.json`` last, so its presence
marks a finished run), holding SIGINT/SIGTERM for the few renames.
"""

import contextlib
import os
import signal
import threading
from pathlib import Path


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
    """

    def __init__(self, directory, names, durable: bool = True):
        self.files = {name: AtomicFile(Path(directory) / name, durable) for name in names}

    def __getitem__(self, name) -> AtomicFile:
        return self.files[name]

    def commit(self) -> None:
        """Rename every file to its final name, in order (interrupts held)."""
        pending = list(self.files.values())
        with deferred_interrupts():
            try:
                while pending:
                    pending[0].commit()
                    pending.pop(0)
            finally:
                for f in pending:
                    f.discard()

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
def deferred_interrupts():
    """Hold SIGINT and SIGTERM until the block ends, then deliver them.

    Only in the main thread (elsewhere signals cannot be handled and the block
    runs unprotected).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received = []
    sigs = [signal.SIGINT] + ([signal.SIGTERM] if hasattr(signal, "SIGTERM") else [])
    old = {sig: signal.signal(sig, lambda signum, frame: received.append(signum)) for sig in sigs}
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
        if received:
            signal.raise_signal(received[0])


def write_text_atomic(path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file."""
    with AtomicFile(path) as f:
        f.tmp.write_text(text, encoding="utf-8")
