"""inins.gnss is pure numerics that imports only inins.core (and the exceptions), and the
GNSS readers in inins.io do not import it (io never imports method packages)."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "inins"
ALLOWED = (
    "numpy",
    "typing",
    "scipy",
    "numba",
    "dataclasses",
    "enum",
    "inins.core",
    "inins.exceptions",
    "inins.gnss",
)
READERS = ("rinex_text.py", "rinex_nav.py", "rinex_obs.py", "psins_tc.py", "flight_layout.py")


def _imports(path):
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{path.name}: relative import"
            yield node.module


@pytest.mark.parametrize("path", sorted((PACKAGE / "gnss").glob("*.py")), ids=lambda p: p.name)
def test_gnss_imports_only_the_core(path):
    bad = [n for n in _imports(path) if not any(n == a or n.startswith(a + ".") for a in ALLOWED)]
    assert bad == []


@pytest.mark.parametrize("name", READERS)
def test_gnss_readers_do_not_import_method_packages(name):
    names = list(_imports(PACKAGE / "io" / name))
    assert not [n for n in names if n.startswith(("inins.gnss", "inins.ekf", "inins.table"))]


def test_importing_gnss_loads_no_io():
    code = (
        "import numpy, scipy, scipy.stats, numba, sys\nbefore = set(sys.modules)\n"
        "import inins.gnss.spp, inins.gnss.simulate, inins.gnss.constellation\n"
        "print(sorted(m for m in set(sys.modules) - before if m.split('.')[0] in "
        "('h5py', 'yaml', 'typer', 'rich', 'pydantic') or m.startswith('inins.io')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
