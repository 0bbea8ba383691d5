"""The wheel's build hook (``setup.py``) runs the warm-up where the build requirements are.

pip builds a wheel in an isolated environment whose packages reach the interpreter
through ``PYTHONPATH``; a warm-up started without it finds no numpy, and the wheel
ships no kernels (every first run compiles).
"""

import importlib.util
import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _hook():
    spec = importlib.util.spec_from_file_location("inins_setup", ROOT / "setup.py")
    module = importlib.util.module_from_spec(spec)
    # setup.py calls setup() at import: load only its definitions
    source = (
        (ROOT / "setup.py")
        .read_text()
        .replace('setup(cmdclass={"build_py": BuildPyWithKernels})', "")
    )
    exec(compile(source, str(ROOT / "setup.py"), "exec"), module.__dict__)
    return module


def test_the_warm_up_keeps_the_build_environment_on_its_path(tmp_path):
    overlay = str(tmp_path / "pip-build-env" / "site")
    env = _hook().warmup_environment(
        str(tmp_path / "build" / "lib"),
        {"PYTHONPATH": overlay, "NUMBA_CACHE_DIR": "/elsewhere", "HOME": "/home/x"},
    )
    assert env["PYTHONPATH"].split(os.pathsep) == [str(tmp_path / "build" / "lib"), overlay]
    assert "NUMBA_CACHE_DIR" not in env and env["HOME"] == "/home/x"


def test_without_a_build_environment_the_path_is_the_build_tree(tmp_path):
    env = _hook().warmup_environment(str(tmp_path), {})
    assert env["PYTHONPATH"] == str(tmp_path)
