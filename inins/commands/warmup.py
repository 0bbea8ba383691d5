"""Compile every numerical kernel once, so that the first command run is quick.

``python -m inins.commands.warmup`` (``make kernels``, run by ``make demo``, ``make
test`` and ``make bench``): each kernel module's ``warm_up()`` compiles its one
specialisation into numba's on-disk cache, and short runs of run-ekf and
observability compile the EKF, GNSS and observability kernels the way their
commands call them; later processes load them instead of compiling. Then the
kernels a short run needs are compiled ahead of time into the kernel library
(:mod:`inins.core.jit`), which a run loads without numba.
"""

import importlib
import sys
import time

from inins.core import jit

MODULES = ("inins.core.pulses", "inins.core.imu", "inins.core.strapdown", "inins.table.kinematics")
_WAIT = ("flight.legs=[{kind: wait, duration_s: 20}]",)
SHORT_RUNS = (  # (command, shipped scenario (folder, name), --set overrides)
    ("run-ekf", ("run-ekf", "default"), _WAIT),
    ("run-ekf", ("paper003", "ekf1-ff"), _WAIT),
    ("observability", ("observability", "default"), ()),
    ("observability", ("observability", "ekf26-bank-turns"), ()),
)
"""Runs (no output written) whose kernels have no ``warm_up()`` of their own."""


def warm_up(progress=None):
    """Compile (or load from the cache) every kernel; ``progress(text)`` per step."""
    jit.activate()
    for name in MODULES:
        if progress is not None:
            progress(name)
        importlib.import_module(name).warm_up()
    from inins.commands import find_command
    from inins.commands.execute import execute
    from inins.io.resources import config_path

    for command, (folder, name), overrides in SHORT_RUNS:
        if progress is not None:
            progress(f"{command} {folder}/{name}")
        execute(find_command(command), config_path(folder, name), overrides, seed=0)


def main():
    start = time.perf_counter()
    print("numerical kernels: compiling, or loading numba's cache ...", flush=True)
    warm_up(lambda step: print(f"  {step}", flush=True))
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
