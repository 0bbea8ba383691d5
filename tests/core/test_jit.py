"""Kernels compile on first use, and short runs take the kernel library (inins.core.jit).

The library is the same kernels compiled ahead of time: a run through it must give
the outputs of a run through numba bit for bit, without loading numba; a call it
was not built for, or a library that no longer matches the sources, goes to numba.
"""

import json
import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import h5py
import numpy as np
import pytest

from inins.core import jit

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "inins"


def test_arguments_are_described_as_numba_types_them():
    numba = jit.activate()
    base = np.arange(12.0).reshape(3, 4)
    readonly = np.zeros(3)
    readonly.flags.writeable = False
    values = [
        base,
        base.T,  # Fortran order
        base[:, ::2],  # neither
        np.zeros((1, 3)),  # both: numba says C
        readonly,
        np.zeros(3, np.int32),
        np.zeros(2, np.bool_),
        True,
        np.bool_(False),
        3,
        2.5,
        np.float64(1.0),
        np.float32(1.0),
        np.int32(3),
        (np.zeros(2), np.zeros((2, 2))),
        (base, base),
        np.random.default_rng(0),
    ]
    described = [jit._describe(v) for v in values]
    assert described == [jit._describe_type(numba.typeof(v)) for v in values]
    # C, F and strided layouts and read-only arrays are told apart, as numba does
    assert len({json.dumps(d) for d in described[:5]}) == 4
    # the cheap key a library kernel remembers its choice by decides the description:
    # equal keys, equal descriptions (another byte order: another key)
    swapped = np.zeros(3, ">f8")
    for a in [*values, swapped, np.zeros(3), np.zeros((1, 3)).T, np.zeros(3)[::2]]:
        for b in [*values, swapped]:
            if jit._key(a) == jit._key(b):
                assert jit._describe(a) == jit._describe(b), (a, b)
    assert jit._key(swapped) != jit._key(np.zeros(3))


def test_importing_every_module_loads_no_numba():
    modules = [
        ".".join(p.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
        for p in sorted(PACKAGE.rglob("*.py"))
        if p.name != "__main__.py"
    ]
    code = (
        "import importlib, sys\n"
        f"for m in {modules!r}:\n"
        "    importlib.import_module(m)\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numba', 'llvmlite')))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False, cwd=ROOT
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def _manifest(directory, **changes):
    (Path(directory) / "library.so").write_bytes(b"")
    sources = jit._source_key(["core/pulses.py"])
    manifest = {
        "format": jit._FORMAT,
        "cpu": jit._host_cpu(),
        "library": "library.so",
        "python": sysconfig.get_config_var("EXT_SUFFIX"),
        "versions": jit._versions(),
        "sources": sources,
        "exports": {},
    }
    manifest.update(changes)
    jit._manifest_path(directory).write_text(json.dumps(manifest))


def test_a_library_is_used_only_while_it_matches_the_sources_and_versions(tmp_path):
    assert jit.library_status(tmp_path / "none") == (
        False,
        f"no kernel library in {tmp_path / 'none'}",
    )
    _manifest(tmp_path)
    assert jit.library_status(tmp_path)[0]
    _manifest(tmp_path, sources={"core/pulses.py": "0" * 64})
    assert jit.library_status(tmp_path) == (
        False,
        "a kernel module changed since the library was built",
    )
    _manifest(tmp_path, versions={"numpy": "1.0", "numba": "0.1"})
    usable, reason = jit.library_status(tmp_path)
    assert not usable and reason.startswith("built for {'numpy': '1.0'")
    other = {"vendor": "AuthenticAMD", "model": "AMD EPYC 7763", "flags": "fpu sse2 avx2"}
    _manifest(tmp_path, cpu=other)
    assert jit.library_status(tmp_path) == (False, "built for another processor (AMD EPYC 7763)")
    _manifest(tmp_path, cpu=None)  # a generic build (pycc's default CPU) runs anywhere
    assert jit.library_status(tmp_path)[0]
    _manifest(tmp_path, format=1)
    assert jit.library_status(tmp_path) == (False, "a library of another layout (1)")


RUN = """
import json, runpy, sys
import numpy as np
sys.argv = ["inins", "simulate-table", "-o", sys.argv[1]]  # the default: 319 400 samples
try:
    runpy.run_module("inins", run_name="__main__")
except SystemExit as exc:
    code = exc.code
after_run = "numba" in sys.modules
from inins.core import pulses
weights = np.array([1e-6, 2e-6, 4e-6])
values = np.arange(12.0).reshape(4, 3) * weights
same = pulses.counts_from_increments(values, weights)
after_library_call = "numba" in sys.modules
fortran = np.asfortranarray(values)  # a layout the library was not built for
counts = np.empty((4, 3), np.int32)
problem = pulses._counts_kernel(fortran, 1.0 / weights, counts)
print(json.dumps({
    "code": code,
    "numba_after_run": after_run,
    "numba_after_library_call": after_library_call,
    "numba_after_other_layout": "numba" in sys.modules,
    "counts_equal": bool(problem == 0 and np.array_equal(counts, same)),
}))
"""


BUDGET = """
import json, sys
import numpy as np
from inins.core import jit, pulses
weights = np.array([1e-6, 2e-6, 4e-6])
rows = np.arange(3 * (jit.LIBRARY_ROWS // 2 + 1), dtype=float).reshape(-1, 3) * weights
compiled = jit._compiled("inins.core.pulses._counts_kernel")
built_native = compiled.native
loaded = {"native": [], "generic": []}
results = []
for kind in ("native", "generic"):  # a library for this processor, then a generic one
    compiled.native = kind == "native"
    for _ in range(2):  # the generic library: within the budget, then past it (numba)
        results.append(pulses.counts_from_increments(rows, weights))
        loaded[kind].append("numba" in sys.modules)
equal = all(np.array_equal(r, results[0]) for r in results)
print(json.dumps({**loaded, "built_native": built_native, "equal": equal}))
"""


DEFAULT_RUN = """
import json, runpy, sys
sys.argv = ["inins", sys.argv[2], "-o", sys.argv[1]]
try:
    runpy.run_module("inins", run_name="__main__")
except SystemExit as exc:
    code = exc.code
print(json.dumps([code, "numba" in sys.modules]))
"""


def _child(script, kernel_dir, *args):
    """The last line of ``python -c script args`` with the kernel library of
    ``kernel_dir`` (an empty folder: numba's), read as JSON."""
    env = {**os.environ, "ININS_KERNEL_DIR": str(kernel_dir)}
    done = subprocess.run(
        [sys.executable, "-c", script, *map(str, args)],
        capture_output=True,
        text=True,
        check=False,
        cwd=ROOT,
        env=env,
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def _datasets(path):
    found = {}

    def keep(name, obj):
        if isinstance(obj, h5py.Dataset) and obj.shape:
            found[name] = obj[()]

    with h5py.File(path, "r") as f:
        f.visititems(keep)
    return found


def _library_for_the_test(tmp_path):
    """The kernel library the install step built (``make kernels``, which ``make test``
    runs first), while it matches the sources and versions; else one built here by
    the warm-up's ``--library-only`` (a build that fails, fails the test)."""
    if jit.library_status()[0]:
        return jit.library_dir()
    library = tmp_path / "library"
    done = subprocess.run(
        [sys.executable, "-m", "inins.commands.warmup", "--library-only"],
        capture_output=True,
        text=True,
        check=False,
        cwd=ROOT,
        env={**os.environ, "ININS_KERNEL_DIR": str(library)},
    )
    assert done.returncode == 0, done.stderr
    assert "run-ekf" not in done.stdout, done.stdout  # the library needs no EKF run
    assert "kernel library built" in done.stdout, done.stdout + done.stderr
    assert jit.library_status(library)[0]
    return library


def test_library_only_warm_up_compiles_what_the_library_takes_and_builds_it(monkeypatch):
    """``--library-only`` runs each module's warm_up() and the short runs of the
    library's commands, then builds it, without the other short runs; the full
    warm-up builds the library before those runs."""
    import importlib

    import inins.commands
    from inins.commands import execute, warmup

    steps = []
    monkeypatch.setattr(warmup.jit, "activate", lambda: None)
    for name in warmup.MODULES:
        module = importlib.import_module(name)
        monkeypatch.setattr(module, "warm_up", lambda name=name: steps.append(name))
    monkeypatch.setattr(inins.commands, "find_command", lambda command: command)
    monkeypatch.setattr(
        execute, "execute", lambda command, path, *a, **k: steps.append(path.parent.name)
    )
    monkeypatch.setattr(warmup, "_library", lambda: steps.append("build"))
    library_runs = [f for c, (f, _), _ in warmup.SHORT_RUNS if c in warmup.LIBRARY_RUNS]
    other_runs = [f for c, (f, _), _ in warmup.SHORT_RUNS if c not in warmup.LIBRARY_RUNS]
    assert library_runs == ["observability", "observability"] and "run-ekf" in other_runs
    warmup.main(["--library-only"])
    assert steps == [*warmup.MODULES, *library_runs, "build"]
    steps.clear()
    warmup.main([])
    assert steps == [*warmup.MODULES, *library_runs, "build", *other_runs]


@pytest.mark.slow
def test_a_run_through_the_library_is_the_run_through_numba_without_numba(tmp_path):
    library = _library_for_the_test(tmp_path)
    manifest = json.loads(jit._manifest_path(library).read_text())
    assert manifest["nogil"]  # every function lets other threads run (numba 0.59-0.68)
    assert manifest["cpu"] == jit._host_cpu()  # compiled for this processor where known
    through_library = _child(RUN, library, tmp_path / "aot")
    assert through_library == {
        "code": 0,
        "numba_after_run": False,
        "numba_after_library_call": False,
        "numba_after_other_layout": True,
        "counts_equal": True,
    }
    through_numba = _child(RUN, tmp_path / "empty", tmp_path / "jit")
    assert through_numba["numba_after_run"]

    assert _child(BUDGET, library) == {
        "native": [False, False],  # no row budget: as fast as numba's copy
        "generic": [False, True],  # 1.1-1.6 times slower: long runs go to numba
        "built_native": jit._host_cpu() is not None,
        "equal": True,
    }

    aot = _datasets(tmp_path / "aot" / "simulate-table.h5")
    numba_run = _datasets(tmp_path / "jit" / "simulate-table.h5")
    assert aot.keys() == numba_run.keys()
    assert len(aot) > 10
    for name, value in aot.items():
        assert np.array_equal(value, numba_run[name]), name

    # the default observability and run-ekf runs: their kernels are in the library too
    # (run-ekf's filter epoch, orbits and flight truth, with its truth in a second thread)
    for command in ("observability", "run-ekf"):
        loaded = {
            name: _child(DEFAULT_RUN, kernels, tmp_path / f"{command}-{name}", command)
            for name, kernels in (("aot", library), ("jit", tmp_path / "empty"))
        }
        assert loaded == {"aot": [0, False], "jit": [0, True]}, command
        aot = _datasets(tmp_path / f"{command}-aot" / f"{command}.h5")
        numba_run = _datasets(tmp_path / f"{command}-jit" / f"{command}.h5")
        assert aot.keys() == numba_run.keys() and len(aot) > 3
        for name, value in aot.items():
            if name != "epochs/update_time":  # the wall time of each epoch step
                assert np.array_equal(value, numba_run[name], equal_nan=True), (command, name)


CALLEE = "from inins.core import jit\n\n\n@jit.njit\ndef offset(x):\n    return x + {}\n"
CALLER = (
    "from inins.core import _probe_callee, jit\n\n\n"
    "@jit.njit(cache=True)\ndef twice(x):\n    return 2.0 * _probe_callee.offset(x)\n"
)
PROBE = (
    "import json\nfrom inins.core import jit, _probe_caller\njit.activate()\n"
    "value = _probe_caller.twice(1.0)\n"
    "print(json.dumps([value, sum(_probe_caller.twice.stats.cache_hits.values())]))\n"
)


def test_an_edit_of_a_callee_in_another_module_recompiles_the_cached_caller(tmp_path):
    """numba stamps a cached kernel with its own file only: the caller would keep the
    old callee. Keyed on every kernel source, the edit recompiles it (issue: stale
    kernels); an edit outside the kernel sources keeps the cache."""
    import shutil

    package = tmp_path / "inins"
    shutil.copytree(PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
    callee = package / "core" / "_probe_callee.py"
    callee.write_text(CALLEE.format("1.0"))
    (package / "core" / "_probe_caller.py").write_text(CALLER)
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "ININS_KERNEL_DIR": str(tmp_path / "no")}
    env.pop("NUMBA_CACHE_DIR", None)

    def probe():
        done = subprocess.run(
            [sys.executable, "-c", PROBE],
            capture_output=True,
            text=True,
            check=False,
            cwd=tmp_path,
            env=env,
        )
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout)

    assert probe() == [4.0, 0]  # compiled and cached
    command = package / "commands" / "warmup.py"  # not a kernel source
    command.write_text(command.read_text() + "\n# edited\n")
    assert probe() == [4.0, 1]  # loaded from the cache: the edit keeps it
    callee.write_text(CALLEE.format("2.0"))  # the callee only: the caller's file is unchanged
    assert probe() == [6.0, 0]
    assert probe() == [6.0, 1]


def test_kernel_sources_are_the_kernel_modules_and_what_they_import():
    sources = jit.kernel_sources()
    # kernels calling across modules: step -> ekf.kernels, strapdown -> earth (inlined)
    for name in ("ekf/step.py", "ekf/kernels.py", "core/strapdown.py", "core/earth.py"):
        assert name in sources
    assert "core/units.py" in sources  # constants numba freezes into a kernel
    assert not any(s.startswith(("commands/", "cli/", "io/", "scenario/")) for s in sources)


@pytest.mark.slow
def test_a_run_on_a_fresh_install_says_what_it_compiles(tmp_path):
    """No numba cache and no kernel library (a fresh ``pip install``): the run names
    the compile as it starts and reports progress; the next run loads and is quiet."""
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
        "ININS_KERNEL_DIR": str(tmp_path / "none"),
    }
    args = [sys.executable, "-m", "inins", "simulate-table", "-o", str(tmp_path / "out")]
    args += ["--set", "imu.sample_rate_hz=20"]

    def run():
        done = subprocess.run(args, capture_output=True, text=True, check=False, env=env)
        assert done.returncode == 0, done.stderr
        return done.stderr

    first = run()
    assert "inins simulate-table: compiling numerical kernels for this machine" in first
    assert "kernels compiled" in first
    assert "compiling" not in run()


def test_a_library_checks_its_sources_by_size_and_time_then_by_content(tmp_path):
    stats = jit._source_stats(["core/pulses.py"])
    _manifest(tmp_path, stats=stats)
    assert jit.library_status(tmp_path)[0]  # stats match: no hashing
    touched = {"core/pulses.py": [stats["core/pulses.py"][0], 1]}
    _manifest(tmp_path, stats=touched)
    assert jit.library_status(tmp_path)[0]  # stats differ, content the same
    _manifest(tmp_path, stats=touched, sources={"core/pulses.py": "0" * 64})
    assert jit.library_status(tmp_path) == (
        False,
        "a kernel module changed since the library was built",
    )


def test_an_interrupt_inside_a_library_call_is_raised_when_it_returns(monkeypatch):
    """A library function may call back into Python (its first BLAS product imports
    scipy's BLAS module); the run's signal handler must not raise there (numba aborts
    the process when that lookup fails) but after the call, whose work is complete."""
    import signal

    from inins import cli
    from inins.io import atomic

    steps = []

    def library_copy(x):  # stands for a compiled function calling back into Python
        if not steps:
            signal.raise_signal(signal.SIGTERM)  # the handler runs here, inside the call
        steps.append("finished")
        return 2.0 * x

    kernel = jit.Kernel(lambda x: 2.0 * x, {})
    compiled = jit._Compiled([(library_copy, [jit._describe(1.0)])], True)
    monkeypatch.setattr(jit, "_compiled", lambda name: compiled)
    monkeypatch.setattr(atomic, "_stop_requested", None)
    previous = signal.signal(signal.SIGTERM, cli._terminate)
    try:
        with pytest.raises(KeyboardInterrupt):
            kernel(1.0)
        assert steps == ["finished"]  # the call ran to its end
        assert atomic._stop_requested == signal.SIGTERM  # and no group commit follows
        assert kernel(1.5) == 3.0  # nothing left over: the next call just runs
    finally:
        signal.signal(signal.SIGTERM, previous)
        atomic._stop_requested = None
