"""Scratch stores for long runs: arrays backed by temporary memory-mapped files.

:func:`memmap_store` gives the ``store(name, shape, dtype)`` callable that
:func:`inins.ekf.loose.run_loose` and :func:`inins.ekf.smoother.smooth` write their
per-epoch arrays to, so that a long run keeps its covariances on disk (the page
cache) rather than in the heap. The files live in a temporary directory removed
when the context exits.
"""

import contextlib
import tempfile
from pathlib import Path

import numpy as np


@contextlib.contextmanager
def memmap_store(prefix="inins-ekf-"):
    """Context manager yielding ``store(name, shape, dtype=float) -> np.memmap``."""
    with tempfile.TemporaryDirectory(prefix=prefix) as tmp:

        def store(name, shape, dtype=float):
            path = Path(tmp) / f"{name}.npy"
            return np.lib.format.open_memmap(path, mode="w+", dtype=dtype, shape=tuple(shape))

        # removing the files unmaps nothing: arrays still referenced stay valid (POSIX)
        yield store
