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
