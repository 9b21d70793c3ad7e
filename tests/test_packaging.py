"""Installed like any Python package: the wheel, not the source tree, runs its demo, checks and serves its
shipped scenarios by name from an empty directory, and writes nothing into site-packages.

The wheel is built offline from a copy of the tree (``--no-build-isolation``: the test extra brings the
setuptools it needs) and installed without dependencies into a fresh venv that reaches the project venv's
packages through a ``.pth`` line (so nothing is downloaded, and the editable install's finder is not run).
"""

from __future__ import annotations

import asyncio
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest
from mcp import Client, StdioServerParameters

REPO = Path(__file__).resolve().parents[1]
IGNORED = shutil.ignore_patterns(".venv", ".git", "out", ".cache", "build", "dist", "*.egg-info", "__pycache__",
                                 ".pytest_cache")


def installed_files(package_dir: Path) -> set[str]:
    return {str(p.relative_to(package_dir)) for p in package_dir.rglob("*")
            if p.is_file() and "__pycache__" not in p.parts}  # Numba's and Python's caches are not outputs


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(the venv's bin directory, the installed package's directory)."""
    root = tmp_path_factory.mktemp("wheel")
    source = root / "source"
    shutil.copytree(REPO, source, symlinks=True, ignore=IGNORED)
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--quiet", str(source),
                    "-w", str(root / "dist")], check=True, capture_output=True, text=True)
    wheel = next((root / "dist").glob("agentic_mpc-*.whl"))
    venv = root / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    purelib = Path(subprocess.run([str(venv / "bin" / "python"), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                                  check=True, capture_output=True, text=True).stdout.strip())
    (purelib / "project-dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    subprocess.run([sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python"), "install", "--no-deps",
                    "--no-index", "--quiet", str(wheel)], check=True, capture_output=True, text=True)
    return venv / "bin", purelib / "agentic_mpc"


def cli(bin_dir: Path, cwd: Path, *args: str, timeout_s: float = 300) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "AGENTIC_MPC_SUMO_NETS")}
    env["OMP_NUM_THREADS"] = "1"
    return subprocess.run([str(bin_dir / "agentic-mpc"), *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout_s)


def test_the_wheel_carries_the_scenarios_and_nets_and_is_what_runs(installed, tmp_path):
    bin_dir, package = installed
    files = installed_files(package)
    assert "shipped-data/scenarios/paper_emergency_response.yaml" in files
    assert "shipped-data/sumo_nets/curvy.net.xml" in files
    where = subprocess.run([str(bin_dir / "python"), "-c", "import agentic_mpc; print(agentic_mpc.__file__)"],
                           cwd=tmp_path, capture_output=True, text=True, check=True).stdout
    assert Path(where.strip()).parent == package


def test_demo_check_and_scenarios_work_from_an_empty_directory(installed, tmp_path):
    bin_dir, package = installed
    before = installed_files(package)
    demo = cli(bin_dir, tmp_path, "demo", "--trials", "1")
    assert demo.returncode == 0, demo.stderr
    assert "message_left" in demo.stdout and (tmp_path / "out" / "obstacle_demo" / "results.csv").is_file()
    check = cli(bin_dir, tmp_path, "check", "paper_steering_preference")
    assert check.returncode == 0, check.stderr
    assert "ok (paper_steering_preference" in check.stdout
    assert "the shipped scenario" in check.stderr and str(package) in check.stderr
    listing = cli(bin_dir, tmp_path, "scenarios")
    assert listing.returncode == 0 and "paper_emergency_response  [SUMO]  variants: yield, no_message" in listing.stdout
    unknown = cli(bin_dir, tmp_path, "run", "paper_emergency_responce")
    assert unknown.returncode == 2 and "paper_emergency_response" in unknown.stderr  # the known names are listed
    copied = cli(bin_dir, tmp_path, "scenarios", "--copy", "paper_emergency_response", "mine")
    assert copied.returncode == 0, copied.stderr
    assert cli(bin_dir, tmp_path / "mine", "check", "paper_emergency_response.yaml").returncode == 0
    assert installed_files(package) == before  # outputs went to the current directory only


def test_serve_over_stdio_answers_tools_list(installed, tmp_path):
    bin_dir, _ = installed
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    params = StdioServerParameters(command=str(bin_dir / "agentic-mpc"), args=["serve", "--transport", "stdio"],
                                   cwd=str(tmp_path), env={**env, "OMP_NUM_THREADS": "1"})

    async def tool_names():
        async with Client(params, cache=None) as client:
            return sorted(tool.name for tool in (await client.list_tools()).tools)

    names = asyncio.run(asyncio.wait_for(tool_names(), 120))
    assert {"run_left_lane", "set_preferred_steering_direction", "set_reference_speed"} <= set(names)
