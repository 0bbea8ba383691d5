"""io/ reads and writes files and never loads a scenario (issue 30: the one upward arrow,
``io/rawlog.py`` importing ``scenario.base.load_scenario`` lazily, is gone): every import
of every io module, lazy imports inside functions included."""

import ast
from pathlib import Path

import inins

IO = Path(inins.__file__).parent / "io"


def _imports(path):
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module


def test_no_io_module_imports_scenario_commands_or_methods():
    upward = ("inins.scenario", "inins.commands", "inins.cli", "inins.sweep")
    methods = ("inins.table", "inins.calibration", "inins.gnss", "inins.ekf")
    found = {
        path.name: sorted(m for m in _imports(path) if m.startswith(upward + methods))
        for path in sorted(IO.glob("*.py"))
    }
    assert len(found) >= 20
    assert {k: v for k, v in found.items() if v} == {}
