"""The project's import graph: dependencies point one way, model <- control_design <- closed_loop -> fmu.

Every ``import`` / ``from ... import`` statement of every module under model/,
control_design/, closed_loop/, fmu/ and workbench/ (module level or inside a
function: a lazy import is a dependency all the same) is read with ``ast``;
relative imports are resolved against the importing module.
"""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PACKAGES = ("model", "control_design", "closed_loop", "fmu", "workbench")
#: Which packages each package may import (besides itself).
ALLOWED = {
    "model": set(),
    "control_design": {"model"},
    "fmu": {"model"},
    "closed_loop": {"model", "control_design", "fmu"},
    "workbench": {"model", "control_design", "closed_loop", "fmu"},
}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path) -> set[str]:
    """Project modules imported by the module at ``path`` (absolute dotted names)."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                stem = ".".join(base + ([node.module] if node.module else []))
            else:
                stem = node.module or ""
            targets = [stem] + [f"{stem}.{alias.name}" for alias in node.names]
        else:
            continue
        found.update(t for t in targets if t.split(".")[0] in PACKAGES)
    return found


def import_graph() -> dict[str, set[str]]:
    """Module -> the project modules it imports (names resolved to existing modules)."""
    files = {_module_name(p): p for pkg in PACKAGES for p in (REPO / pkg).rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in files.items():
        edges = set()
        for target in _imports(path):
            while target and target not in files:  # ``from pkg.mod import name``: the module is the prefix
                target = target.rpartition(".")[0]
            if target and target != name:
                edges.add(target)
        graph[name] = edges
    return graph


def _package_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    pkg_graph: dict[str, set[str]] = {p: set() for p in PACKAGES}
    for src, targets in graph.items():
        for dst in targets:
            a, b = src.split(".")[0], dst.split(".")[0]
            if a != b:
                pkg_graph[a].add(b)
    state: dict[str, int] = {}

    def visit(node: str, trail: list[str]) -> list[str] | None:
        state[node] = 1
        for nxt in sorted(pkg_graph[node]):
            if state.get(nxt) == 1:
                return trail + [node, nxt]
            if nxt not in state:
                found = visit(nxt, trail + [node])
                if found:
                    return found
        state[node] = 2
        return None

    for p in PACKAGES:
        if p not in state:
            found = visit(p, [])
            if found:
                return found
    return None


def test_the_graph_is_read():
    """Negative control: known edges are found, so an empty graph cannot pass the other tests."""
    graph = import_graph()
    assert "control_design.laws" in graph["control_design.controllers"]
    assert "fmu.build" in graph["closed_loop.controller_fmu"]
    assert "model.dynamics.workspace" in graph["model.dynamics.core"]


def test_packages_import_only_the_layers_below_them():
    bad = sorted(f"{src} -> {dst}" for src, targets in import_graph().items() for dst in targets
                 if dst.split(".")[0] != src.split(".")[0]
                 and dst.split(".")[0] not in ALLOWED[src.split(".")[0]])
    assert bad == []


def test_fmu_knows_nothing_of_controllers():
    edges = sorted(f"{src} -> {dst}" for src, targets in import_graph().items() if src.split(".")[0] == "fmu"
                   for dst in targets if dst.split(".")[0] in ("control_design", "closed_loop"))
    assert edges == []
    # the package's lazy exports (PEP 562, model.lazy) name fmu's own modules only
    import fmu

    assert fmu._EXPORTS and all((REPO / "fmu" / f"{name}.py").is_file() for name in fmu._EXPORTS), fmu._EXPORTS


def test_no_package_cycle():
    assert _package_cycle(import_graph()) is None


def _module_cycles(graph: dict[str, set[str]], packages: tuple[str, ...]) -> list[list[str]]:
    """Strongly connected groups of more than one module among the modules of ``packages``."""
    nodes = [m for m in graph if m.split(".")[0] in packages]
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    groups: list[list[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w.split(".")[0] not in packages:
                continue
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                groups.append(sorted(group))

    for v in nodes:
        if v not in index:
            connect(v)
    return groups


def test_no_module_cycle_in_the_control_layers():
    """Within control_design and closed_loop no two modules import each other, even lazily."""
    graph = import_graph()
    assert _module_cycles(graph, ("control_design", "closed_loop")) == []
    # negative control: a cycle added to a copy of the graph is found
    graph["closed_loop.schedule"] = graph["closed_loop.schedule"] | {"closed_loop.simulate"}
    assert _module_cycles(graph, ("control_design", "closed_loop")) == [["closed_loop.schedule",
                                                                           "closed_loop.simulate"]]


def test_no_module_cycle_in_any_package():
    """No two modules of the project import each other, directly or through others, even lazily."""
    graph = import_graph()
    assert _module_cycles(graph, PACKAGES) == []
    # negative control: the loader importing back from the description is found as a cycle
    graph["model.description"] = graph["model.description"] | {"model.loading"}
    assert _module_cycles(graph, PACKAGES) == [["model.description", "model.example_robots", "model.loading", "model.urdf",
                                                  "model.urdf_xml"]]


LIBRARY = ("model", "control_design", "closed_loop", "fmu")


def _front_end_uses(path: Path) -> list[str]:
    """argparse / matplotlib.pyplot imports and ``matplotlib.use`` calls in the module at ``path``."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            names = [node.module or ""] + [f"{node.module}.{alias.name}" for alias in node.names]
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "use"
              and isinstance(node.func.value, ast.Name) and node.func.value.id == "matplotlib"):
            found.append(f"{path.relative_to(REPO)}: matplotlib.use")
        found += [f"{path.relative_to(REPO)}: {n}" for n in names
                  if n.split(".")[0] == "argparse" or n.startswith("matplotlib.pyplot")]
    return found


def test_library_packages_hold_no_command_line_or_pyplot():
    """argparse and pyplot belong to the front end (workbench/); nothing calls matplotlib.use."""
    bad = [hit for pkg in LIBRARY for path in sorted((REPO / pkg).rglob("*.py")) for hit in _front_end_uses(path)]
    assert bad == []
    assert [h for h in _front_end_uses(REPO / "workbench" / "animation.py") if "matplotlib.use" in h] == []
    # negative control: the CLI itself does import argparse, and is found
    assert _front_end_uses(REPO / "workbench" / "cli.py") == ["workbench/cli.py: argparse"]
