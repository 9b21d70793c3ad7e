"""The layers import one way (docs/architecture.md), modules stay small, and light paths stay light."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "agentic_mpc"

FORBIDDEN = {
    # layer: what it must not import
    "controller": ("world", "sumo", "mcp", "agent", "scenario", "run", "batch", "commands"),
    "primitives": ("controller", "world", "sumo", "mcp", "agent", "scenario", "run", "batch", "commands"),
    "world": ("sumo", "mcp", "agent", "scenario", "run", "batch", "commands"),
    "sumo": ("mcp", "agent", "scenario", "run", "batch", "commands", "controller"),
    "mcp": ("sumo", "agent", "scenario", "run", "batch", "commands", "controller"),
    "agent": ("mcp.server", "mcp.tools", "sumo", "world.plain", "scenario", "run", "batch", "commands", "controller"),
    "run": ("sumo", "scenario.runner", "batch", "commands"),
    "batch": ("sumo", "mcp", "agent", "run", "controller", "world", "commands"),
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


def test_only_the_bridge_imports_libsumo():
    importers = sorted(str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
                       if "libsumo" in {n.split(".")[0] for n in _all_imports(p)})
    assert importers == ["sumo/bridge.py"]


def _all_imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return names


def test_modules_stay_small():
    # about 400 lines, one job each; the libsumo bridge is the one exception (every line there talks to SUMO)
    limits = {"sumo/bridge.py": 540}
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
