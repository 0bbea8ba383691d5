"""Compile every numerical kernel once, so that the first command run is quick.

``python -m inins.commands.warmup`` (``make demo`` and ``make test`` run it after
installing): each kernel module's ``warm_up()`` compiles its one specialisation into
numba's on-disk cache, which later processes load instead of compiling; then the
kernels a short run needs are compiled ahead of time into the kernel library
(:mod:`inins.core.jit`), which a run loads without numba.
"""

import importlib
import sys
import time

from inins.core import jit

MODULES = ("inins.core.pulses", "inins.core.imu", "inins.core.strapdown", "inins.table.kinematics")


def warm_up(progress=None):
    """Compile (or load from the cache) every kernel; ``progress(text)`` per module."""
    jit.activate()
    for name in MODULES:
        if progress is not None:
            progress(name)
        importlib.import_module(name).warm_up()


def main():
    start = time.perf_counter()
    print("numerical kernels: compiling, or loading numba's cache ...", flush=True)
    warm_up()
    print(f"numerical kernels ready ({time.perf_counter() - start:.1f} s)", flush=True)
    usable, reason = jit.library_status()
    if usable:
        print(f"kernel library up to date ({reason})")
        return
    print(f"building the kernel library for short runs ({reason}) ...", flush=True)
    start = time.perf_counter()
    try:
        path = jit.build_library()
    except Exception as exc:  # the library is an optimisation: numba serves every call
        print(
            f"kernel library not built ({type(exc).__name__}: {exc}); runs use numba",
            file=sys.stderr,
        )
        return
    print(f"kernel library built in {time.perf_counter() - start:.1f} s: {path.name}")


if __name__ == "__main__":
    main()
