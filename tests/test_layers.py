"""The package's layers (issue 15): folders by pipeline stage, no import circles, no upward imports.

Law: the import graph drawn from the code (every ``import`` statement, including those inside
functions) has no cycle between modules, and a module of one layer imports only its own
layer and the layers below it. The library never imports the command line, and no module
below the command line imports the ``warp_st`` facade (``warp_st/__init__.py``).
"""
from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "warp_st"

#: Bottom to top. A layer may import itself and anything to its left. ``testing`` (oracles
#: shared by the tests and the benchmarks) sits on top: nothing in the library imports it.
LAYERS = ("core", "kernels", "output", "usd", "spacetime", "accel", "rendering", "jobs", "commands", "testing")


def _modules() -> dict[str, Path]:
    mods = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        mods[name] = path
    return mods


def import_graph() -> dict[str, set[str]]:
    """{module: modules of warp_st it imports}, from the source text."""
    mods = _modules()
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for name, path in mods.items():
        package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(path.read_text())):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join(up + ([base] if base else []))
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
            for t in targets:
                while t and t not in mods:
                    t = t.rpartition(".")[0]
                if t and t != name:
                    graph[name].add(t)
    return graph


def _layer(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) >= 2 and parts[1] in LAYERS else None


def test_every_module_sits_in_a_layer():
    """Only the facade (``warp_st``) and ``__main__`` live outside the layer folders."""
    loose = sorted(m for m in _modules() if _layer(m) is None and m not in ("warp_st", "warp_st.__main__"))
    assert loose == []


def test_no_upward_imports():
    bad = []
    for module, imports in import_graph().items():
        low = _layer(module)
        if low is None:
            continue
        for target in imports:
            high = _layer(target)
            if high is None:  # the facade: only the command line may use it
                if target == "warp_st" and low not in ("commands", "testing"):
                    bad.append(f"{module} -> {target}")
            elif LAYERS.index(high) > LAYERS.index(low):
                bad.append(f"{module} -> {target}")
    assert bad == []


def test_no_import_cycles():
    graph = import_graph()
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    cycles = []

    def visit(v):  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert cycles == []


def test_no_module_over_600_lines():
    long = {str(p.relative_to(PACKAGE)): n for p in PACKAGE.rglob("*.py")
            if (n := len(p.read_text().splitlines())) > 600}
    assert long == {}
