"""The same seed gives the same CSVs on any x86-64-v3 processor (agentic_mpc/reproducibility.py).

One machine stands in for two: a short traffic scenario runs in two fresh processes, once as the host
runs it and once with OpenBLAS's kernel, Numba's code generation and NumPy's dispatch restricted to a
baseline instruction set; the child reports what it really ran with, so that a restriction that silently
did not apply cannot pass for one. Before the fix the trajectories parted at row 735 (a 2-vector ``@`` in
J0's time gap went through OpenBLAS's CPU-specific ``ddot``).
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from agentic_mpc.reproducibility import caveat, cpu_flags
from tests.golden.cases import FILES, comparable

REPO = Path(__file__).resolve().parents[1]
SCENARIO = REPO / "scenarios" / "emergency_rescue_lane_traffic.yaml"

CHILD = """
import ctypes, glob, json, os, sys
import numpy, numba
from numpy._core._multiarray_umath import __cpu_features__
def blas_core():
    for path in glob.glob(os.path.join(os.path.dirname(numpy.__file__) + ".libs", "libscipy_openblas*.so")):
        name = getattr(ctypes.CDLL(path), "scipy_openblas_get_corename64_", None)
        if name is not None:
            name.restype = ctypes.c_char_p
            return name().decode()
    return None
import llvmlite.binding as llvm
json.dump({"blas_core": blas_core(), "numba_cpu": numba.config.CPU_NAME or llvm.get_host_cpu_name(),
           "numpy_features_on": sorted(k for k, v in __cpu_features__.items() if v)}, open(sys.argv[1], "w"))
from agentic_mpc.cli import main
sys.exit(main(sys.argv[2:]))
"""


def baseline_environment(cache_dir: Path) -> dict[str, str]:
    """BLAS on a pre-AVX kernel, Numba compiling for Haswell (x86-64-v3), NumPy without its dispatched
    AVX2 / AVX-512 loops, and a Numba cache of its own (a cache compiled for the host would be reused)."""
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

    dispatched = [name for name in __cpu_dispatch__ if __cpu_features__.get(name)]
    return {"OPENBLAS_CORETYPE": "Nehalem", "NUMBA_CPU_NAME": "haswell", "NUMBA_CACHE_DIR": str(cache_dir),
            "NPY_DISABLE_CPU_FEATURES": " ".join(dispatched)}


def run(out: Path, extra_env: dict[str, str]) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_CORETYPE", "NUMBA_CPU_NAME",
                                                            "NPY_DISABLE_CPU_FEATURES", "NUMBA_CACHE_DIR")}
    env.update(extra_env, PYTHONPATH=str(REPO))
    report = out.with_suffix(".json")
    done = subprocess.run([sys.executable, "-c", CHILD, str(report), "run", str(SCENARIO), "--variant", "hold",
                           "--seed", "3", "--out", str(out)], env=env, cwd=REPO, capture_output=True, text=True)
    assert done.returncode == 0, f"the run with {extra_env or 'the host settings'} failed:\n{done.stderr[-3000:]}"
    return json.loads(report.read_text())


@pytest.mark.skipif(platform.machine().lower() not in ("x86_64", "amd64"), reason="the promise covers x86-64")
def test_traffic_run_is_identical_with_baseline_instruction_sets(tmp_path):
    baseline = baseline_environment(tmp_path / "numba-cache")
    with ThreadPoolExecutor(2) as pool:  # one process a core
        host_job = pool.submit(run, tmp_path / "host", {})
        base_job = pool.submit(run, tmp_path / "baseline", baseline)
        host_job.result()
        base = base_job.result()
    # The restriction took effect in the child, not just in its environment.
    assert base["numba_cpu"] == "haswell"
    if base["blas_core"] is not None:
        assert base["blas_core"] == "Nehalem"
    disabled = set(baseline["NPY_DISABLE_CPU_FEATURES"].split())
    assert not disabled & set(base["numpy_features_on"])
    for name in FILES:
        host_rows = comparable(tmp_path / "host" / name).splitlines()
        base_rows = comparable(tmp_path / "baseline" / name).splitlines()
        assert len(host_rows) > (1400 if name == "trajectory.csv" else 1)  # the run went past row 735
        parted = next((i for i, (a, b) in enumerate(zip(host_rows, base_rows)) if a != b), None)
        assert host_rows == base_rows, f"{name}: the runs part at row {parted}"
    # The recorded plan (the replay's) too: it is rolled out by the reference path, not by the kernel.
    assert (tmp_path / "host" / "plan.csv").read_bytes() == (tmp_path / "baseline" / "plan.csv").read_bytes()


def test_caveat_names_what_breaks_the_promise():
    assert caveat("x86_64", frozenset({"avx2", "fma", "sse2"})) is None
    assert caveat("AMD64", None) is None  # flags unknown (no /proc/cpuinfo): assumed x86-64-v3
    assert "lacks fma" in caveat("x86_64", frozenset({"avx2", "sse2"}))
    assert "lacks avx2 and fma" in caveat("x86_64", frozenset({"sse2"}))
    assert "aarch64 machine" in caveat("aarch64", None)


def test_cpu_flags_reads_the_first_processor(tmp_path):
    info = tmp_path / "cpuinfo"
    info.write_text("processor\t: 0\nflags\t\t: fpu avx2 fma\n\nprocessor\t: 1\nflags\t\t: fpu\n")
    assert cpu_flags(info) == frozenset({"fpu", "avx2", "fma"})
    assert cpu_flags(tmp_path / "missing") is None


def test_a_run_on_another_architecture_says_so_once(monkeypatch, caplog):
    import agentic_mpc.reproducibility as reproducibility

    monkeypatch.setattr(reproducibility.platform, "machine", lambda: "riscv64")
    monkeypatch.setattr(reproducibility, "_warned", False)
    with caplog.at_level("WARNING", logger="agentic_mpc.reproducibility"):
        assert "riscv64" in reproducibility.warn_once()
        reproducibility.warn_once()
    assert [r.getMessage() for r in caplog.records].count(caplog.records[0].getMessage()) == 1
    assert "riscv64 machine" in caplog.records[0].getMessage()


ORDER_CHILD = """
from agentic_mpc.scenario.runner import build_world
from agentic_mpc.scenario.schema import load_scenario
from agentic_mpc.shipped import scenario_path
world = build_world(load_scenario(scenario_path("incident_in_traffic")).variant("left"))
print(",".join(o.id for o in world.observation.obstacles), ",".join(c.label for c in world.obstacle_circles()))
world.close()
"""


def test_obstacles_keep_the_scenarios_order_whatever_the_string_hashing():
    """A set of obstacle ids once ordered them by the process's string hashing: J2's obstacles and the
    obstacle that ``obstacle_side`` reports changed from process to process (found in the incident's goldens)."""
    seen = set()
    for hash_seed in ("1", "2", "3"):
        env = {**os.environ, "PYTHONHASHSEED": hash_seed, "PYTHONPATH": str(REPO)}
        done = subprocess.run([sys.executable, "-c", ORDER_CHILD], env=env, cwd=REPO, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr[-2000:]
        seen.add(done.stdout.strip().splitlines()[-1])
    ids, labels = seen.pop().split(" ")
    assert not seen and ids == "stopped_straight,stopped_curve" and labels.startswith("stopped_straight")
