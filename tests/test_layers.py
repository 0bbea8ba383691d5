"""The layers stay separate (spec §9).

The import contract lives in ``pyproject.toml`` (``[tool.importlinter]``) and
``lint-imports`` checks it in ``make lint``. Here: the contract holds on this tree,
breaks when a forbidden import is added (so it is not a contract that cannot fail),
and importing the numeric core and the method packages does not load typer, rich,
yaml, h5py or pydantic at run time (``lint-imports`` sees only our own import
statements; this sees what actually gets loaded).
"""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "inins"
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")
PURE = ("core", "table", "calibration", "gnss", "ekf", "observability")
EDGE = ("typer", "rich", "yaml", "h5py", "pydantic")
ALLOWED_FIRST = ("numpy", "scipy", "scipy.linalg", "scipy.stats", "scipy.interpolate", "numba")

pytestmark = pytest.mark.skipif(not LINT_IMPORTS.exists(), reason="import-linter not installed")


def _lint(root):
    return subprocess.run(
        [str(LINT_IMPORTS), "--no-cache"],
        cwd=root,
        capture_output=True,
        text=True,
        check=False,
        env={"PYTHONPATH": str(root), "PATH": ""},
    )


def _copy_tree(tmp_path):
    shutil.copytree(PACKAGE, tmp_path / "inins", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    return tmp_path


def test_the_import_contract_holds():
    done = _lint(ROOT)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "0 broken" in done.stdout


FORBIDDEN = {  # a new import -> the contract it breaks
    ("core/rotation.py", "from inins.io import hdf5"): "core imports nothing else of inins",
    ("calibration/bias.py", "import h5py"): "core and the method packages do no I/O",
    ("io/summary.py", "from inins.calibration import bias"): "io and the scenario models never",
    ("scenario/run_ekf.py", "from inins.ekf import filter"): "io and the scenario models never",
    (
        "scenario/base.py",
        "from inins.commands import execute",
    ): "io and scenario never import commands",
    (
        "scenario/noise.py",
        "from inins.scenario.si import table",
    ): "the scenario models never import",
    ("commands/execute.py", "from inins.cli import _runner"): "commands never import sweep or cli",
    ("gnss/__init__.py", "from inins.table import kinematics"): "the GNSS layer imports only",
    ("ekf/kernels.py", "import numba"): "only core.jit imports numba",
}


def test_each_forbidden_import_breaks_its_contract(tmp_path):
    root = _copy_tree(tmp_path)
    for (module, line), _ in FORBIDDEN.items():
        path = root / "inins" / module
        path.write_text(path.read_text() + f"\n{line}  # forbidden\n")
    done = _lint(root)
    assert done.returncode != 0
    broken = [row for row in done.stdout.splitlines() if " BROKEN" in row]
    for contract in FORBIDDEN.values():
        assert any(row.startswith(contract) for row in broken), (contract, done.stdout)


def test_every_scenario_model_is_held_from_its_converters():
    """The contract names the scenario modules one by one: a new one must join it."""
    import tomllib

    contracts = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    (held,) = [
        c["source_modules"]
        for c in contracts["contracts"]
        if c["name"] == "the scenario models never import their converters"
    ]
    models = {
        f"inins.scenario.{p.stem}"
        for p in (PACKAGE / "scenario").glob("*.py")
        if p.stem != "__init__"
    }
    assert models == set(held)


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def test_importing_loads_no_edge_library():
    packages = {
        sub: [_module_name(p) for p in sorted((PACKAGE / sub).rglob("*.py"))] for sub in PURE
    }
    code = (
        "import importlib, json, sys\n"
        f"for m in {ALLOWED_FIRST!r}:\n"
        "    importlib.import_module(m)\n"
        "out = {}\n"
        f"for sub, modules in {packages!r}.items():\n"
        "    before = set(sys.modules)\n"
        "    for m in modules:\n"
        "        importlib.import_module(m)\n"
        "    out[sub] = sorted(set(sys.modules) - before)\n"
        "print(json.dumps(out))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False, cwd=ROOT
    )
    assert done.returncode == 0, done.stderr
    loaded = json.loads(done.stdout.strip().splitlines()[-1])
    bad = {sub: [m for m in mods if m.split(".")[0] in EDGE] for sub, mods in loaded.items()}
    assert bad == {sub: [] for sub in PURE}
