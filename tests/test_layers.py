"""The import rules of docs/architecture.md, read from the source (ast): the kernel at the
bottom, each stage importing only the kernel and the stages before it, the API and the
command line at the top, optimize's parts in an order of their own, the other stages
entering optimize only by its front door, and no import cycle between modules."""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

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
#: optimize's parts, bottom first: a module of optimize may import its own part and below
OPTIMIZE_ORDER = (
    ("optimize.kinds", "optimize.paper_model", "optimize.sweep_folder",  # vocabulary, data
     "optimize.cycles", "optimize.plots"),
    ("optimize.model",),  # the kite DAE, aerodynamics, drivetrain, winding temperature
    ("optimize.problem",),  # the optimal control problem, its parts
    ("optimize.system",),  # the system file (the parts' sections) and the drive in force
    ("optimize.resolve",),  # system, drive and OCP options resolved once
    ("optimize.solve",),  # its solution
    ("optimize.analysis",),  # the result check, the paper comparison
    ("optimize.service",),  # the one solve service: plans, chains, executors
    ("optimize.sweep",),  # a sweep's frames and trust checks
    ("optimize.sweep_options",),
    ("optimize.command",),  # bench optimize as a library call
    ("optimize.cli",),
    ("optimize.door",),  # the front door: all the other stages use of optimize
    ("optimize",),  # the package itself
)
#: what a module outside optimize may import of it: its front door and the sweep folder
OPTIMIZE_DOORS = ("optimize.door", "optimize.sweep_folder")


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


@functools.cache
def _parsed(text: str) -> tuple[ast.AST, ...]:
    """Every node of a module's source (parsed once per source text: the tests parse the
    same 300 modules many times)."""
    return tuple(ast.walk(ast.parse(text)))


def nodes(path: Path) -> tuple[ast.AST, ...]:
    """Every node of the module at ``path``, as it is now."""
    return _parsed(path.read_text(encoding="utf-8"))


def import_graph(mods: dict[str, Path]) -> dict[str, set[str]]:
    """Module -> the product modules it imports (at the top or inside a function)."""

    def resolve(name: str) -> str | None:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = {}
    for name, path in mods.items():
        targets = set()
        for node in nodes(path):
            if isinstance(node, ast.Import):
                wanted = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                wanted = [node.module, *(f"{node.module}.{a.name}" for a in node.names)]
            else:
                wanted = lazy_imports(node)
            targets |= {resolve(w) for w in wanted if w.split(".")[0] in PACKAGES}
        graph[name] = targets - {None, name}
    return graph


def lazy_imports(node: ast.AST) -> list[str]:
    """The modules of a ``LAZY_IMPORTS = {module: names}`` table (:mod:`kernel.lazy`)."""
    if not (isinstance(node, ast.Assign) and len(node.targets) == 1
            and isinstance(node.targets[0], ast.Name) and node.targets[0].id == "LAZY_IMPORTS"):
        return []
    return list(ast.literal_eval(node.value))


def within(module: str, prefix: str) -> bool:
    return module == prefix or module.startswith(prefix + ".")


def layer(module: str) -> int:
    return next(rank for prefix, rank in LAYERS if within(module, prefix))


def optimize_rank(module: str) -> int:
    """The rank of an optimize module's part in :data:`OPTIMIZE_ORDER`."""
    return next(rank for rank, parts in enumerate(OPTIMIZE_ORDER)
                if any(within(module, p) for p in parts))


def rule_breaks(graph: dict[str, set[str]]) -> list[str]:
    """Every import against the rules: upward between layers, upward between optimize's
    parts, and into optimize from outside other than by its doors."""
    out = []
    for a, targets in graph.items():
        for b in targets:
            inside = within(a, "optimize") and within(b, "optimize")
            if layer(b) > layer(a):
                out.append(f"{a} -> {b}: upward")
            elif inside and optimize_rank(b) > optimize_rank(a):
                out.append(f"{a} -> {b}: upward inside optimize")
            elif within(b, "optimize") and not inside and b not in OPTIMIZE_DOORS:
                out.append(f"{a} -> {b}: not by optimize's front door")
    return sorted(out)


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


def test_every_import_looks_down_and_enters_optimize_by_its_door():
    assert rule_breaks(import_graph(modules())) == []


def test_every_optimize_module_has_a_part():
    mods = [m for m in modules() if within(m, "optimize")]
    assert all(isinstance(optimize_rank(m), int) for m in mods)
    assert {m.split(".")[1] for m in mods if m != "optimize"} == {
        p.split(".")[1] for parts in OPTIMIZE_ORDER for p in parts if p != "optimize"}


def test_no_stage_imports_the_api_or_the_command_line():
    graph = import_graph(modules())
    top = {m for m in graph if layer(m) == 7}
    assert sorted(f"{a} -> {b}" for a, t in graph.items() if a not in top
                  for b in t if b in top) == []


def test_the_api_takes_nothing_from_the_report():
    # the API's results and figures come from the stages; the report consumes them too
    graph = import_graph(modules())
    api = [m for m in graph if within(m, "drivebench") and m != "drivebench.cli"]
    assert sorted(f"{a} -> {b}" for a in api for b in graph[a] if within(b, "reports")) == []


def test_no_import_cycle():
    assert cycles(import_graph(modules())) == []


def test_the_checks_see_a_violation():
    # the walker finds an upward import and a cycle when there is one
    graph = {"kernel.files": {"energy.aep"}, "energy.aep": {"kernel.files"}}
    assert layer("kernel.files") < layer("energy.aep")
    assert cycles(graph) == [["energy.aep", "kernel.files"]]
    assert "bench.ingest.cli" in modules() and layer("bench.ingest.cli") == 1


@pytest.mark.parametrize("source, target, why", [
    ("bench.ingest.pipeline", "optimize.door", "upward"),  # a function-level import too
    ("energy.sizing", "optimize.service.solves", "not by optimize's front door"),
    ("optimize.model.aero", "optimize.system.system", "upward inside optimize"),
    ("optimize.service.run", "optimize.sweep.outputs", "upward inside optimize"),
])
def test_a_wrong_import_written_into_a_module_fails_the_rules(tmp_path, source, target, why):
    # a copy of the product packages with one wrong import added inside a function
    mods = modules()
    assert rule_breaks(import_graph(mods)) == []
    path = tmp_path / (source.replace(".", "/") + ".py")
    path.parent.mkdir(parents=True)
    path.write_text(mods[source].read_text(encoding="utf-8")
                    + f"\n\ndef _wrong():\n    from {target} import something\n",
                    encoding="utf-8")
    assert rule_breaks(import_graph({**mods, source: path})) == [f"{source} -> {target}: {why}"]


def test_a_lazy_table_counts_as_imports(tmp_path):
    path = tmp_path / "lazy.py"
    path.write_text('LAZY_IMPORTS = {"energy.aep": ("aep_mwh",)}\n', encoding="utf-8")
    mods = {**modules(), "kernel.lazy_example": path}
    assert "kernel.lazy_example -> energy.aep: upward" in rule_breaks(import_graph(mods))


def private_imports(mods: dict[str, Path]) -> list[str]:
    """Every ``from <product module> import _name``: a private name used outside its module."""
    found = []
    for name, path in mods.items():
        for node in nodes(path):
            if (isinstance(node, ast.ImportFrom) and node.module
                    and node.module.split(".")[0] in PACKAGES):
                found += [f"{name} imports {node.module}.{a.name}" for a in node.names
                          if a.name.startswith("_") and not a.name.startswith("__")]
    return found


def test_no_module_imports_another_modules_private_name():
    assert private_imports(modules()) == []


def test_the_private_import_check_sees_one(tmp_path):
    path = tmp_path / "probe.py"
    path.write_text("from cycle.verify import _hidden\n", encoding="utf-8")
    assert private_imports({"cycle.probe": path}) == ["cycle.probe imports cycle.verify._hidden"]
