"""Compile every numerical kernel once, so that the first command run is quick.

``python -m inins.commands.warmup`` (``make kernels``, run by ``make demo``, ``make
test`` and ``make bench``): each kernel module's ``warm_up()`` compiles its one
specialisation into numba's on-disk cache, and short runs of shipped scenarios
(run-ekf tight and loose with smoothing and aiding, observability, a GLONASS
import-flight, calibrate-imu, noise) compile the kernels the way their commands
call them; later processes load them instead of compiling. Then the
kernels a short run needs are compiled ahead of time into the kernel library
(:mod:`inins.core.jit`), which a run loads without numba.

``--library-only`` runs just what the kernel library needs (the modules'
``warm_up()`` and the observability runs, which compile its ``aot`` kernels) and
builds it, skipping the other short runs (for a test of the library).
"""

import importlib
import sys
import time

from inins.core import jit

MODULES = (
    "inins.core.pulses",
    "inins.core.imu",
    "inins.core.strapdown",
    "inins.table.kinematics",
    "inins.ekf.flight_kernel",
    "inins.ekf.filter",
    "inins.gnss.orbit",
    "inins.gnss.glonass",
)
_WAIT = ("flight.legs=[{kind: wait, duration_s: 20}]", "filter.turning_from_s=0")
SHORT_RUNS = (  # (command, shipped scenario (folder, name), --set overrides)
    ("run-ekf", ("run-ekf", "default"), _WAIT),
    ("run-ekf", ("paper003", "ekf1-ff"), _WAIT),
    ("observability", ("observability", "default"), ()),
    ("observability", ("observability", "ekf26-bank-turns"), ()),
    ("run-ekf", ("run-ekf", "lc-drive-15s-aided"), ()),  # loose, RTS smoother, aiding
    ("import-flight", ("import-flight", "smartloc-gps-glonass"), ()),  # GLONASS orbits
    ("calibrate-imu", ("calibrate-imu", "default"), ()),
    ("calibrate-imu", ("calibrate-imu", "table-free-mems"), ()),
    ("noise", ("noise", "simulated-hold"), ()),
)
"""Runs (no output written) whose kernels have no ``warm_up()`` of their own."""
LIBRARY_RUNS = ("observability",)
"""Commands whose short runs compile ``aot`` kernels of the library (``--library-only``)."""


class CompileNotice:
    """What a run says while numba compiles kernels (a :func:`inins.core.jit.on_compile`
    listener): the first run after an install, an upgrade or an edit of a kernel
    source compiles for this machine (a few seconds to half a minute); later runs
    load the compiled code.

    ``echo(text)`` prints one line: a first line when the first compile starts,
    then at most one a second (``every_s``) with the count of kernels compiled so
    far and the time spent, so the screen never sits frozen without a word.
    """

    def __init__(self, label, echo, every_s=1.0):
        self.label, self.echo, self.every_s = label, echo, every_s
        self.count, self.start, self.last = 0, None, None

    def __call__(self, event, name, seconds):
        now = time.perf_counter()
        if self.start is None:
            self.start = self.last = now
            self.echo(
                f"{self.label}: compiling numerical kernels for this machine (once after "
                "an install or upgrade; later runs load them) ..."
            )
        if event != "done":
            return
        self.count += 1
        if now - self.last >= self.every_s:
            self.last = now
            short = name.removeprefix("inins.")
            self.echo(
                f"{self.label}:   {self.count} kernels compiled, {now - self.start:.0f} s "
                f"(last: {short})"
            )


def warm_up(progress=None, part="all"):
    """Compile (or load from the cache) every kernel; ``progress(text)`` per step.

    ``part``: ``"library"`` the kernels of the kernel library (the modules'
    ``warm_up()`` and the short runs of :data:`LIBRARY_RUNS`), ``"rest"`` the other
    short runs, ``"all"`` both.
    """
    jit.activate()
    if part in ("library", "all"):
        for name in MODULES:
            if progress is not None:
                progress(name)
            importlib.import_module(name).warm_up()
    from inins.commands import find_command
    from inins.commands.execute import execute
    from inins.io.resources import config_path

    for command, (folder, name), overrides in SHORT_RUNS:
        if part != "all" and (command in LIBRARY_RUNS) != (part == "library"):
            continue
        if progress is not None:
            progress(f"{command} {folder}/{name}")
        execute(find_command(command), config_path(folder, name), overrides, seed=0)


def main(argv=None):
    """Compile the library's kernels, build the kernel library, then (unless
    ``--library-only``) compile the other kernels through the remaining short runs.

    The library is built before those runs: a kernel the library holds may gain a
    second specialisation in them (a loose-coupling kernel calls the strapdown with
    read-only arrays), and the library takes one.
    """
    args = sys.argv[1:] if argv is None else argv
    unknown = [arg for arg in args if arg != "--library-only"]
    if unknown:
        sys.exit(f"warm-up: unknown argument {unknown[0]!r} (takes only --library-only)")
    start = time.perf_counter()
    print("numerical kernels: compiling, or loading numba's cache ...", flush=True)
    warm_up(_echo, part="library")
    _library()
    if "--library-only" not in args:
        warm_up(_echo, part="rest")
    print(f"numerical kernels ready ({time.perf_counter() - start:.1f} s)", flush=True)


def _echo(step):
    print(f"  {step}", flush=True)


def _library():
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
