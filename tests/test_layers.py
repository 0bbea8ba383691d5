"""The layers stay separate: the numeric core and the method packages do no I/O.

``inins.core`` may not import typer, rich, yaml, h5py, pydantic, ``inins.io``
or ``inins.cli``; the method packages (``inins.table``, ``inins.calibration``)
may not import typer, rich, yaml, h5py or ``inins.cli``. Checked twice: on
the source (every import statement, also inside functions) and by importing
the modules in a fresh interpreter and looking at what they add to
``sys.modules``. The allowed numeric libraries are imported first, because
they load some of these themselves (numba reads its config with yaml).
"""

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "inins"
CORE_FORBIDDEN = ("typer", "rich", "yaml", "h5py", "pydantic", "inins.io", "inins.cli")
METHOD_FORBIDDEN = ("typer", "rich", "yaml", "h5py", "inins.cli")
RULES = {"core": CORE_FORBIDDEN, "table": METHOD_FORBIDDEN, "calibration": METHOD_FORBIDDEN}
ALLOWED_FIRST = ("numpy", "scipy", "scipy.linalg", "scipy.stats", "scipy.interpolate", "numba")


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imported(path: Path):
    """Absolute names of every module an import statement in ``path`` names."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = (
        _module_name(path) if path.name == "__init__.py" else _module_name(path).rpartition(".")[0]
    )
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, *([base] if base else [])])
            yield node.lineno, base
            for alias in node.names:
                yield node.lineno, f"{base}.{alias.name}"


def _violates(name: str, forbidden) -> bool:
    return any(name == f or name.startswith(f + ".") for f in forbidden)


def _files(sub: str):
    return sorted((PACKAGE / sub).rglob("*.py"))


@pytest.mark.parametrize("sub", sorted(RULES))
def test_sources_import_nothing_forbidden(sub):
    bad = [
        f"{path.relative_to(PACKAGE.parent)}:{line}: {name}"
        for path in _files(sub)
        for line, name in _imported(path)
        if _violates(name, RULES[sub])
    ]
    assert bad == [], "\n".join(bad)


def test_import_walker_sees_relative_and_nested_imports(tmp_path, monkeypatch):
    fake = PACKAGE / "core" / "x.py"
    source = "def f():\n    import h5py\nfrom .. import io\nfrom ..cli import app\n"
    monkeypatch.setattr(Path, "read_text", lambda self, encoding=None: source)
    names = [name for _, name in _imported(fake)]
    assert {"h5py", "inins.io", "inins.cli"} <= set(names)


@pytest.mark.parametrize("sub", sorted(RULES))
def test_importing_loads_nothing_forbidden(sub):
    modules = [_module_name(p) for p in _files(sub)]
    code = (
        "import importlib, json, sys\n"
        f"for m in {ALLOWED_FIRST!r}:\n"
        "    importlib.import_module(m)\n"
        "before = set(sys.modules)\n"
        f"for m in {modules!r}:\n"
        "    importlib.import_module(m)\n"
        "print(json.dumps(sorted(set(sys.modules) - before)))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    loaded = json.loads(done.stdout.strip().splitlines()[-1])
    bad = sorted(m for m in loaded if _violates(m, RULES[sub]))
    assert bad == [], f"importing inins.{sub} loads {bad}"
