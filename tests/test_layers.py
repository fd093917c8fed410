"""The import rules of docs/architecture.md, read from the source (ast): the kernel at the
bottom, each stage importing only the kernel and the stages before it, the API and the
command line at the top, and no import cycle between modules."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("kernel", "bench", "fitting", "optimize", "energy", "cycle", "reports", "drivebench")
#: (module prefix, layer), most specific first: a module may import its own layer and below
LAYERS = (
    ("kernel", 0),
    ("bench.synth", 2),  # writes raw campaigns as ingest reads them
    ("bench", 1),  # ingest and the store
    ("fitting", 3),
    ("optimize", 4),
    ("energy", 5),
    ("cycle", 5),  # the cycle round trip: reads optimize folders and the store
    ("reports", 6),
    ("drivebench", 7),  # the Python API and the command line: the top
)


def modules() -> dict[str, Path]:
    """Every module of the product packages, by dotted name."""
    out = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            out[".".join(parts)] = path
    return out


def import_graph(mods: dict[str, Path]) -> dict[str, set[str]]:
    """Module -> the product modules it imports (at the top or inside a function)."""

    def resolve(name: str) -> str | None:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = {}
    for name, path in mods.items():
        targets = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                wanted = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                wanted = [node.module, *(f"{node.module}.{a.name}" for a in node.names)]
            else:
                continue
            targets |= {resolve(w) for w in wanted if w.split(".")[0] in PACKAGES}
        graph[name] = targets - {None, name}
    return graph


def layer(module: str) -> int:
    return next(rank for prefix, rank in LAYERS
                if module == prefix or module.startswith(prefix + "."))


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found = []

    def visit(v: str) -> None:
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
                found.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_every_import_looks_down():
    graph = import_graph(modules())
    upward = sorted(f"{a} -> {b}" for a, targets in graph.items() for b in targets
                    if layer(b) > layer(a))
    assert upward == []


def test_no_stage_imports_the_api_or_the_command_line():
    graph = import_graph(modules())
    top = {m for m in graph if layer(m) == 7}
    assert sorted(f"{a} -> {b}" for a, t in graph.items() if a not in top
                  for b in t if b in top) == []


def test_no_import_cycle():
    assert cycles(import_graph(modules())) == []


def test_the_checks_see_a_violation():
    # the walker finds an upward import and a cycle when there is one
    graph = {"kernel.files": {"energy.aep"}, "energy.aep": {"kernel.files"}}
    assert layer("kernel.files") < layer("energy.aep")
    assert cycles(graph) == [["energy.aep", "kernel.files"]]
    assert "bench.ingest.cli" in modules() and layer("bench.ingest.cli") == 1
