"""Compile every numerical kernel once, so that the first command run is quick.

``python -m inins.commands.warmup`` (``make demo`` and ``make test`` run it after
installing): each kernel module's ``warm_up()`` compiles its one specialisation into
numba's on-disk cache, which later processes load instead of compiling.
"""

import importlib
import time

MODULES = ("inins.core.pulses", "inins.core.imu", "inins.core.strapdown", "inins.table.kinematics")


def warm_up(progress=None):
    """Compile (or load from the cache) every kernel; ``progress(text)`` per module."""
    for name in MODULES:
        if progress is not None:
            progress(name)
        importlib.import_module(name).warm_up()


def main():
    start = time.perf_counter()
    print("compiling numerical kernels (first run only) ...", flush=True)
    warm_up()
    print(f"numerical kernels ready ({time.perf_counter() - start:.1f} s)")


if __name__ == "__main__":
    main()
