"""The layers import one way (docs/architecture.md), modules stay small, and light paths stay light."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "agentic_mpc"

FORBIDDEN = {
    # layer: what it must not import (docs/architecture.md draws the same)
    "controller": ("world", "sumo", "mcp", "agent", "scenario", "run", "batch", "commands", "plots", "replay"),
    "primitives": ("controller", "world", "sumo", "mcp", "agent", "scenario", "run", "batch", "commands", "plots",
                   "replay"),
    "world": ("sumo", "mcp", "agent", "scenario", "run", "batch", "commands", "controller", "plots", "replay"),
    "sumo": ("mcp", "agent", "scenario", "run", "batch", "commands", "controller", "plots", "replay"),
    # the tactics know a world only through its observation and a TacticalRoad: no simulator
    "tactics": ("sumo", "mcp", "agent", "scenario", "run", "batch", "commands", "controller", "plots", "replay",
                "world.plain", "world.base"),
    "mcp": ("sumo", "agent", "scenario", "run", "batch", "commands", "controller", "plots", "replay"),
    "agent": ("mcp.server", "mcp.tools", "mcp.tool_table", "mcp.resources", "mcp.control_server", "sumo",
              "world.plain", "scenario", "run", "batch", "commands", "controller", "plots", "replay"),
    "run": ("sumo", "scenario", "batch", "commands", "plots", "replay"),
    "plots": ("replay", "scenario", "batch", "commands", "mcp", "agent", "controller", "run.loop", "run.recorder"),
    "replay": ("scenario", "batch", "commands", "sumo", "run.loop", "run.recorder"),
    "batch": ("sumo", "mcp", "agent", "controller", "world", "commands", "plots", "replay", "run.loop",
              "run.recorder", "run.metrics", "run.comfort", "run.timeline"),
}


def imports_of(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
        elif isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
    return {name.removeprefix("agentic_mpc.") for name in found if name.startswith("agentic_mpc.")}


@pytest.mark.parametrize("layer", sorted(FORBIDDEN))
def test_imports_point_one_way(layer):
    wrong = [
        f"{path.relative_to(PACKAGE)} imports agentic_mpc.{name}"
        for path in sorted((PACKAGE / layer).rglob("*.py"))
        for name in imports_of(path)
        if any(name == bad or name.startswith(bad + ".") for bad in FORBIDDEN[layer])
    ]
    assert not wrong, "\n".join(wrong)


def package_graph() -> dict[str, set[str]]:
    """Which top-level unit of the package (a subpackage or a module) imports which, lazy imports included."""
    graph: dict[str, set[str]] = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE).parts
        unit = parts[0] if len(parts) > 1 else path.stem
        for name in imports_of(path):
            target = name.split(".")[0]
            if target != unit:
                graph.setdefault(unit, set()).add(target)
    return graph


def test_no_two_packages_import_each_other():
    graph = package_graph()

    def reaches(start: str) -> set[str]:
        seen, todo = set(), [start]
        while todo:
            for target in graph.get(todo.pop(), ()):
                if target not in seen:
                    seen.add(target)
                    todo.append(target)
        return seen

    cycles = sorted({tuple(sorted((a, b))) for a in graph for b in graph[a] if a in reaches(b)})
    assert not cycles, f"import cycles between: {cycles}"


def test_only_the_bridge_imports_libsumo():
    importers = sorted(str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
                       if "libsumo" in {n.split(".")[0] for n in _all_imports(p)})
    assert importers and all(name.startswith("sumo/bridge/") for name in importers), importers


def _all_imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return names


def test_modules_stay_small():
    # about 400 lines, one job each
    limits: dict[str, int] = {}
    big = [f"{p.relative_to(PACKAGE)}: {n} lines" for p in PACKAGE.rglob("*.py")
           if (n := len(p.read_text(encoding="utf-8").splitlines())) > limits.get(str(p.relative_to(PACKAGE)), 420)]
    assert not big, "\n".join(big)


@pytest.mark.parametrize("module, heavy", [
    ("agentic_mpc.scenario.schema", ("libsumo", "sumolib", "numba", "mcp", "pandas", "matplotlib")),
    ("agentic_mpc.cli", ("libsumo", "numba", "mcp", "pandas", "matplotlib", "numpy")),
    ("agentic_mpc.mcp.protocol", ("mcp", "jsonschema", "libsumo")),
    ("agentic_mpc.world.observation", ("libsumo", "sumolib", "numpy", "mcp")),
])
def test_light_modules_load_nothing_heavy(module, heavy):
    code = f"import sys, {module}; print(sorted(m for m in {heavy!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def _module_files() -> dict[str, Path]:
    """Every module of the package by dotted name (a package by its ``__init__.py``)."""
    files = {}
    for path in PACKAGE.rglob("*.py"):
        parts = ("agentic_mpc", *path.relative_to(PACKAGE).with_suffix("").parts)
        files[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return files


def file_graph() -> dict[str, set[str]]:
    """Which file of the package imports which, lazy and type-checking imports included: ``from package
    import name`` is the package's ``__init__`` unless ``name`` is a submodule."""
    files = _module_files()
    graph: dict[str, set[str]] = {}
    for name, path in files.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        targets = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:  # relative: from the importing file's package upwards
                    anchor = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                    base = f"{anchor}.{base}" if base else anchor
                targets.update(f"{base}.{alias.name}" if f"{base}.{alias.name}" in files else base
                               for alias in node.names)
        graph[name] = {target for target in targets if target in files and target != name}
    return graph


def file_circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one file (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    circles.append(sorted(component))
    return sorted(circles)


KNOWN_FILE_CIRCLES: list[set[str]] = []
"""Circles tolerated as they are (none since issue 52 broke the last, world/collisions <-> world/observation)."""


def test_no_circle_of_files():
    circles = file_circles(file_graph())
    unknown = [circle for circle in circles if set(circle) not in KNOWN_FILE_CIRCLES]
    assert not unknown, "files that import each other (in a circle):\n" + "\n".join(map(", ".join, unknown))


def test_the_file_graph_sees_circles():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert file_circles(graph) == [["a", "b", "c"]]
    assert "agentic_mpc.agent.backends.base" in file_graph()["agentic_mpc.agent.backends.chat"]
