"""Kernels compile on first use into numba's on-disk cache, keyed by every kernel
source (inins.core.jit); nothing of numba is loaded before a kernel runs, and no
private numba name is used."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from inins.core import jit

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "inins"


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


PRIVATE = re.compile(
    r"numba\.pycc|pycc|_locator_classes|_CacheLocator|_customize_tm|numba[\w.]*\._"
)


def test_no_private_or_deprecated_numba_name_is_used():
    """numba.pycc is deprecated and private numba attributes change between releases:
    the package uses numba's public decorator, settings and event API only."""
    used = [
        f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
        for path in sorted(PACKAGE.rglob("*.py"))
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if PRIVATE.search(line)
    ]
    assert used == []
    assert not (ROOT / "setup.py").exists()  # no build hook: a pure-Python wheel


def test_every_kernel_is_cached_in_the_folder_of_its_sources_digest(tmp_path, monkeypatch):
    numba = jit.activate()
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    expected = tmp_path / "inins" / f"kernels-{jit.source_digest()[:16]}"
    assert jit.cache_dir() == expected

    @jit.njit
    def cubed(x):
        return x * x * x

    assert cubed(2.0) == 8.0
    assert list(expected.rglob("*.nbi")) and list(expected.rglob("*.nbc"))
    assert numba.config.CACHE_DIR != str(expected)  # set only while the kernel was made


CALLEE = "from inins.core import jit\n\n\n@jit.njit\ndef offset(x):\n    return x + {}\n"
CALLER = (
    "from inins.core import _probe_callee, jit\n\n\n"
    "@jit.njit\ndef twice(x):\n    return 2.0 * _probe_callee.offset(x)\n"
)
PROBE = (
    "import json\nfrom inins.core import jit, _probe_caller\n"
    "value = _probe_caller.twice(1.0)\n"
    "print(json.dumps([value, sum(_probe_caller.twice.stats.cache_hits.values())]))\n"
)


def test_an_edit_of_a_callee_in_another_module_recompiles_the_cached_caller(tmp_path):
    """numba stamps a cached kernel with its own file only: the caller would keep the
    old callee. Cached in the folder of every kernel source's digest, the edit
    recompiles it (and the stale folder goes); an edit outside the kernel sources
    keeps the cache."""
    import shutil

    package = tmp_path / "inins"
    shutil.copytree(PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
    callee = package / "core" / "_probe_callee.py"
    callee.write_text(CALLEE.format("1.0"))
    (package / "core" / "_probe_caller.py").write_text(CALLER)
    cache = tmp_path / "cache"
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "NUMBA_CACHE_DIR": str(cache)}

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
    first = sorted(p.name for p in (cache / "inins").glob("kernels-*"))
    callee.write_text(CALLEE.format("2.0"))  # the callee only: the caller's file is unchanged
    assert probe() == [6.0, 0]
    assert probe() == [6.0, 1]
    second = sorted(p.name for p in (cache / "inins").glob("kernels-*"))
    assert len(first) == len(second) == 1 and first != second  # the stale folder removed


def test_kernel_sources_are_the_kernel_modules_and_what_they_import():
    sources = jit.kernel_sources()
    # kernels calling across modules: step -> ekf.kernels, strapdown -> earth (inlined)
    for name in ("ekf/step.py", "ekf/kernels.py", "core/strapdown.py", "core/earth.py"):
        assert name in sources
    assert "core/units.py" in sources  # constants numba freezes into a kernel
    assert not any(s.startswith(("commands/", "cli/", "io/", "scenario/")) for s in sources)


@pytest.mark.slow
def test_a_run_on_a_fresh_install_says_what_it_compiles(tmp_path):
    """An empty numba cache (a fresh ``pip install``): the run says it compiles and about
    how long it takes; the next run loads the kernels and is quiet."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    args = [sys.executable, "-m", "inins", "simulate-table", "-o", str(tmp_path / "out")]
    args += ["--set", "imu.sample_rate_hz=20"]

    def run():
        done = subprocess.run(args, capture_output=True, text=True, check=False, env=env)
        assert done.returncode == 0, done.stderr
        return done.stderr

    first = run()
    assert "inins simulate-table: compiling numerical kernels for this machine" in first
    assert re.search(r"up to about \d+ s; later runs load them", first)
    assert "compiling" not in run()


def test_the_sources_digest_is_kept_until_a_source_changes(tmp_path):
    """The digest is read from ``sources.json`` while every source's size and time are
    those it was computed from (no hashing in a run); a touched source recomputes it."""
    import shutil

    package = tmp_path / "inins"
    shutil.copytree(PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "NUMBA_CACHE_DIR": str(tmp_path / "c")}
    probe = "from inins.core import jit\nprint(jit.source_digest())\n"

    def digest():
        done = subprocess.run(
            [sys.executable, "-c", probe],
            capture_output=True,
            text=True,
            env=env,
            check=True,
            cwd=tmp_path,
        )
        return done.stdout.strip()

    first = digest()
    memo = tmp_path / "c" / "inins" / "sources.json"
    kept = json.loads(memo.read_text())
    memo.write_text(json.dumps({**kept, "digest": "kept"}))
    assert digest() == "kept"  # read, not recomputed
    strapdown = package / "core" / "strapdown.py"
    strapdown.write_text(strapdown.read_text() + "\n")  # a kernel source changed
    assert digest() not in ("kept", first)
