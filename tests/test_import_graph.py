"""The import graph of the package, lazy imports inside functions included: no command
imports a sibling command (shared code lives in ``commands._*``, a method package or
``scenario/``), and no two modules of ``inins`` import each other through a circle."""

import ast
import functools
from pathlib import Path

import inins

ROOT = Path(inins.__file__).parent


def _module_name(path):
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@functools.cache
def _graph():
    """module -> the inins modules it imports anywhere in its source (parsed once a
    process: both tests read it, neither changes it)."""
    modules = {_module_name(p): p for p in ROOT.rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        tree = ast.parse(path.read_text())
        targets = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                targets.update(a.name for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets.add(node.module)
                # "from inins.commands import figures" imports the submodule
                targets.update(f"{node.module}.{a.name}" for a in node.names)
        graph[name] = {t for t in targets if t in modules and t != name}
    return graph, modules


def _is_command(path):
    return "SCENARIO_MODEL" in path.read_text()


def test_no_command_imports_a_sibling_command():
    graph, modules = _graph()
    commands = {n for n, p in modules.items() if n.startswith("inins.commands.") and _is_command(p)}
    assert len(commands) >= 6
    offending = {c: sorted(graph[c] & commands) for c in commands if graph[c] & commands}
    assert offending == {}


def _strongly_connected(graph):
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on.discard(w)
                comp.add(w)
                if w == v:
                    break
            out.append(comp)

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_no_import_circle():
    graph, _ = _graph()
    # a package's __init__ re-exporting its modules is not a circle of the modules
    graph = {
        m: {t for t in ts if not (inins_pkg(t) and m.startswith(t + "."))}
        for m, ts in graph.items()
    }
    circles = [sorted(c) for c in _strongly_connected(graph) if len(c) > 1]
    assert circles == []


def inins_pkg(name):
    return (ROOT.parent / Path(*name.split(".")) / "__init__.py").exists()
