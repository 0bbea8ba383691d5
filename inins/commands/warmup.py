"""Compile the numerical kernels ahead of the first run (``inins warmup [COMMAND...]``).

A command compiles the kernels it needs on its first run after an install, an
upgrade or an edit of a kernel source, into numba's on-disk cache
(:mod:`inins.core.jit`); later runs load them. ``inins warmup`` does that ahead,
for a lab machine or a CI image: short runs of shipped scenarios (no output
written) make each named command (all by default) compile the kernels its usual
paths call, with the argument types they pass.
"""

import time

from inins.core import jit

_WAIT = ("flight.legs=[{kind: wait, duration_s: 20}]", "filter.turning_from_s=0")
RUNS = {  # command -> ((scenario folder, name, --set overrides), ...)
    "simulate-table": (("simulate-table", "default", ()),),
    "calibrate-bias": (("calibrate-bias", "default", ()),),
    "align-ett": (("align-ett", "default", ()),),
    "import-log": (("import-log", "default", ()),),
    "import-flight": (
        ("import-flight", "default", ()),
        ("import-flight", "smartloc-gps-glonass", ()),  # GLONASS orbits
    ),
    "run-ekf": (
        ("run-ekf", "default", _WAIT),
        ("paper003", "ekf1-ff", _WAIT),
        ("run-ekf", "psins-tc-smoothed", ()),  # recorded drive, tight smoother
        ("run-ekf", "lc-drive-15s-aided", ()),  # loose, RTS smoother, aiding
    ),
    "observability": (
        ("observability", "default", ()),
        ("observability", "ekf26-bank-turns", ()),
    ),
    "calibrate-imu": (
        ("calibrate-imu", "default", ()),
        ("calibrate-imu", "table-free-mems", ()),
        ("calibrate-imu", "system-level-19", ()),
    ),
    "noise": (("noise", "simulated-hold", ()),),
}
"""Short runs whose kernels a command's first run would compile."""

COMPILE_S = {  # the time of `inins warmup COMMAND` with an empty cache
    "simulate-table": 6,
    "calibrate-bias": 12,
    "align-ett": 6,
    "import-log": 1,
    "import-flight": 6,
    "run-ekf": 110,
    "observability": 18,
    "calibrate-imu": 10,
    "noise": 16,
}
"""About how long (s) the kernels of each command's runs take to compile on a two-core
machine (``python -m benchmarks.bench_compile``); a first run, told so, compiles those
its scenario needs."""


class CompileNotice:
    """What a run says while numba compiles kernels (a :func:`inins.core.jit.on_compile`
    listener): a first line when the first compile starts, with the time the whole
    compile takes about, then a line at most every ``every_s`` seconds naming the
    kernel being compiled, the count done and the time spent, so the screen never
    sits silent. ``echo(text)`` prints one line; :meth:`close` ends the lines.

    Parameters
    ----------
    label : str
        The run's name (``inins run-ekf``).
    echo : callable
        Prints one line.
    expected_s : float or None
        About how long the compile takes, if known.
    every_s : float
        Seconds between progress lines (at most).
    """

    def __init__(self, label, echo, expected_s=None, every_s=5.0):
        self.label, self.echo, self.expected_s, self.every_s = label, echo, expected_s, every_s
        self.count, self.start, self.active = 0, None, []
        self.last = None
        self._stop = None

    def __call__(self, event, name, seconds):
        self.last = time.perf_counter()
        if self.start is None:
            self.start = time.perf_counter()
            about = f", up to about {self.expected_s:.0f} s" if self.expected_s else ""
            self.echo(
                f"{self.label}: compiling numerical kernels for this machine (once after an "
                f"install, an upgrade or an edit{about}; later runs load them) ..."
            )
            self._start_ticker()
        if event == "start":
            self.active.append(name)
        else:
            self.count += 1
            if name in self.active:
                self.active.remove(name)

    def line(self) -> str:
        """The progress line of now."""
        spent = time.perf_counter() - self.start
        current = (
            f"compiling {self.active[0].removeprefix('inins.')}"
            if self.active
            else "loading compiled kernels"
        )
        left = ""
        if self.expected_s:
            left = (
                f", about {self.expected_s - spent:.0f} s left"
                if spent < self.expected_s
                else ", longer than usual on this machine"
            )
        return f"{self.label}:   {current} ({self.count} compiled, {spent:.0f} s{left})"

    def _start_ticker(self):
        import threading

        self._stop = threading.Event()

        def tick():
            while not self._stop.wait(self.every_s):
                if self.active or time.perf_counter() - self.last < self.every_s:
                    self.echo(self.line())

        threading.Thread(target=tick, name="inins-compile-notice", daemon=True).start()

    def close(self):
        """No more progress lines (the run is over)."""
        if self._stop is not None:
            self._stop.set()


def warm_up(commands=None, progress=None):
    """Compile (or load from the cache) the kernels of ``commands`` (default: all).

    ``progress(text)`` is told of each short run before it starts.
    """
    for task in tasks(commands):
        _short_run(*task, progress)


def tasks(commands=None):
    """The short runs of ``commands`` (default: all) as ``(command, folder, name,
    overrides)``, the longest compiles first (run-ekf's tight and loose filters)."""
    found = [(c, *run) for c in commands or RUNS for run in RUNS[c]]
    first = [t for t in found if t[:3] in _LONGEST]
    return first + [t for t in found if t[:3] not in _LONGEST]


_LONGEST = (("run-ekf", "run-ekf", "default"), ("run-ekf", "run-ekf", "lc-drive-15s-aided"))


def _short_run(command, folder, name, overrides, progress=None):
    from inins.commands import find_command
    from inins.commands.execute import execute
    from inins.io.resources import config_path

    if progress is not None:
        progress(f"{command}: {folder}/{name}")
    execute(find_command(command), config_path(folder, name), overrides, seed=0)


def main(commands=None, echo=print, jobs=1):
    """Warm up ``commands`` (all by default), telling ``echo`` what compiles; ``jobs``
    processes run the short runs side by side (the longest compiles first)."""
    start = time.perf_counter()
    commands = list(commands or RUNS)
    runs = tasks(commands)
    jobs = max(1, min(jobs, len(runs)))
    if jobs == 1:
        expected = sum(COMPILE_S.get(c, 0) for c in commands)
        notice = jit.on_compile(CompileNotice("inins warmup", echo, expected))
        try:
            warm_up(commands, lambda text: echo(f"  {text}"))
        finally:
            jit.remove_compile_listener(notice)
            notice.close()
    else:
        _in_processes(runs, jobs, echo)
    echo(f"numerical kernels ready for {', '.join(commands)} ({time.perf_counter() - start:.0f} s)")


def _in_processes(runs, jobs, echo):
    """The short runs ``runs`` on ``jobs`` processes, each telling what it compiles."""
    import concurrent.futures
    import multiprocessing

    context = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(jobs, mp_context=context) as pool:
        for done in [pool.submit(_noticed_run, run) for run in runs]:
            done.result()


def _noticed_run(run):
    """One short run in a worker process of :func:`main`, its compiles told on stderr."""
    import sys

    def echo(text):
        print(text, file=sys.stderr, flush=True)

    _, folder, name, _ = run
    notice = jit.on_compile(CompileNotice(f"inins warmup ({folder}/{name})", echo))
    try:
        _short_run(*run, lambda text: echo(f"  {text}"))
    finally:
        jit.remove_compile_listener(notice)
        notice.close()
