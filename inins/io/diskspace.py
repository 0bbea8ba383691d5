"""Free disk space, available memory and full-disk errors: the machine's limits.

Used before a run (is there room for the estimated output?) and while writing
(:class:`inins.io.hdf5_sink.H5SeriesSink` stops before HDF5 itself meets a full
disk, which it does not survive cleanly).
"""

import errno
import os
import re
from pathlib import Path

from inins.exceptions import OutputError

MIN_MARGIN = 1 << 20
"""Smallest margin :func:`margin_for` keeps (bytes)."""
MAX_MARGIN = 64 << 20
"""Largest margin :func:`margin_for` keeps (bytes)."""
_FULL = {errno.ENOSPC, errno.EDQUOT}


def existing_parent(path) -> Path:
    """``path`` or its nearest existing ancestor."""
    path = Path(os.path.abspath(path))
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def free_bytes(path) -> int | None:
    """Bytes an unprivileged user may still write on the file system of ``path``
    (None where unknown)."""
    try:
        st = os.statvfs(existing_parent(path))
    except (OSError, AttributeError):
        return None
    return st.f_bavail * st.f_frsize


def available_memory() -> int | None:
    """Memory available to a new allocation without swapping (bytes; Linux
    ``MemAvailable``), None where unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def device_of(path) -> str:
    """``DEVICE (mounted on MOUNT)`` for the file system holding ``path``."""
    mount = existing_parent(path)
    while not os.path.ismount(mount) and mount != mount.parent:
        mount = mount.parent
    device = None
    try:
        with open("/proc/self/mounts", encoding="utf-8", errors="replace") as f:
            for line in f:
                parts = line.split()
                if len(parts) > 1 and parts[1] == str(mount):
                    device = parts[0]
    except OSError:
        pass
    return f"{device} (mounted on {mount})" if device else str(mount)


def is_disk_full(exc: BaseException) -> bool:
    """True for an error that means the disk (or quota) is full: an OSError with
    ENOSPC/EDQUOT, or an HDF5 error reporting errno 28 (h5py raises RuntimeError)."""
    if isinstance(exc, OSError) and exc.errno in _FULL:
        return True
    if isinstance(exc, OSError | RuntimeError):
        text = str(exc)
        return "errno = 28" in text or "No space left on device" in text
    return False


def disk_full_error(path, detail: str | None = None) -> OutputError:
    """The one message for a full disk while writing ``path`` (a temporary
    ``.NAME.partial-PID`` is named by its final name); ``detail`` (the figures)
    goes in parentheses."""
    path = Path(path)
    match = re.match(r"^\.(.+)\.partial-\d+$", path.name)
    if match:
        path = path.with_name(match.group(1))
    figures = f" ({detail})" if detail else ""
    return OutputError(
        f"no space left on {device_of(path)} writing {path}{figures}; "
        "earlier results untouched, no partial file left"
    )


def margin_for(need: int) -> int:
    """Bytes to keep free beyond ``need`` bytes of writing: a tenth of it (for an
    estimate, its own uncertainty; for an HDF5 file, the metadata HDF5 flushes on
    close, a small fraction of the data), between :data:`MIN_MARGIN` and
    :data:`MAX_MARGIN`."""
    return min(MAX_MARGIN, max(MIN_MARGIN, int(need) // 10))


def mib(n: int) -> str:
    """``n`` bytes as text in MiB (``"0.4 MiB"``)."""
    return f"{n / 2**20:.1f} MiB"


def require_room(path, need: int, what: str) -> None:
    """Raise :class:`~inins.exceptions.OutputError` unless the file system of
    ``path`` has ``need`` bytes plus :func:`margin_for` ``(need)`` free; the message
    states ``what`` needs it, the estimate, the margin and the free space."""
    free = free_bytes(path)
    margin = margin_for(need)
    if free is not None and free < need + margin:
        raise OutputError(
            f"not enough free space on {device_of(path)}: {what} needs about {mib(need)} "
            f"plus a margin of {mib(margin)}, {mib(free)} free; free some space or "
            "choose another output folder"
        )


def check_room(path, need: int) -> None:
    """Raise :class:`~inins.exceptions.OutputError` if the file system of ``path`` (a
    file being written) has fewer than ``need`` more bytes free plus the margin for
    the file's size once they are written (:func:`margin_for`)."""
    free = free_bytes(path)
    if free is None:
        return
    try:
        written = os.stat(path).st_size
    except OSError:
        written = 0
    margin = margin_for(written + need)
    if free < need + margin:
        raise disk_full_error(
            path,
            f"{mib(free)} free, the next write needs {mib(need)} plus a margin of {mib(margin)}",
        )


class FullDiskWatch:
    """Catch HDF5's late reports of a full disk while a file is open.

    HDF5 writes cached metadata when h5py objects are released, and a failed write
    there surfaces only as a printed traceback (``sys.excepthook``) and an "Exception
    ignored" message (``sys.unraisablehook``); after one, flushing or closing the file
    can crash the process. While active, these hooks record disk-full reports (keeping
    them off stderr) so that the writer can stop and abandon the file; other reports
    pass on.
    """

    def __init__(self):
        self.full = False
        self._previous = None

    def __enter__(self):
        import sys

        self._previous = (sys.unraisablehook, sys.excepthook)
        unraisable_hook, except_hook = self._previous

        def on_unraisable(unraisable):
            if is_disk_full(unraisable.exc_value):
                self.full = True
            else:
                unraisable_hook(unraisable)

        def on_exception(kind, value, tb):
            if is_disk_full(value):
                self.full = True
            else:
                except_hook(kind, value, tb)

        sys.unraisablehook, sys.excepthook = on_unraisable, on_exception
        return self

    def __exit__(self, *exc):
        import sys

        if self._previous is not None:
            sys.unraisablehook, sys.excepthook = self._previous
            self._previous = None
        return False
