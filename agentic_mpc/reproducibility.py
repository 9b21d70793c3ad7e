"""What "the same seed gives the same CSV" promises, and the one check a run makes of it.

The promise (docs/reproducibility.md): the same scenario, seed and package versions give byte-identical
``summary.csv``, ``trajectory.csv`` and ``events.csv`` (wall-clock columns aside) on any x86-64 processor
with AVX2 and FMA (x86-64-v3: Intel since Haswell, AMD since Zen), with or without AVX-512. What makes it
hold: no BLAS call on the simulation path (OpenBLAS picks its kernel, and so its summation order, by CPU),
compiled kernels without reassociation or approximate maths (only multiply-add contraction, which gives
the same result on every CPU that has FMA), and no NumPy function on the path whose CPU-dispatched
variants differ (tests/test_reproducibility.py runs a traffic scenario with all three restricted to a
baseline and compares the files byte for byte).

Elsewhere (another architecture, an x86-64 CPU without FMA) a run still works and is still repeatable on
that machine, but its numbers may differ from an x86-64-v3 machine's in the last bits, which traffic can
amplify into another trajectory; :func:`warn_once` says so once per process.
"""

from __future__ import annotations

import logging
import platform
from pathlib import Path

logger = logging.getLogger(__name__)

X86_64 = ("x86_64", "amd64")
REQUIRED_X86_FLAGS = ("avx2", "fma")
"""What the kernels' multiply-add contraction needs to round as it does everywhere else."""

_warned = False


def cpu_flags(cpuinfo: Path = Path("/proc/cpuinfo")) -> frozenset[str] | None:
    """The first processor's feature flags from ``/proc/cpuinfo``; None where there is no such file."""
    try:
        text = cpuinfo.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    for line in text.splitlines():
        key, _, value = line.partition(":")
        if key.strip() == "flags":
            return frozenset(value.split())
    return None


def caveat(machine: str | None = None, flags: frozenset[str] | None = None) -> str | None:
    """Why this machine's numbers may differ from an x86-64-v3 machine's, or None where the promise holds
    (or where the flags cannot be read: the promise is then assumed, as on any x86-64-v3 machine)."""
    machine = (machine if machine is not None else platform.machine()).lower()
    if machine not in X86_64:
        return (f"this is a {machine} machine: runs here repeat on this machine, but the promise of identical "
                f"numbers across machines covers x86-64 processors with AVX2 and FMA only")
    missing = [flag for flag in REQUIRED_X86_FLAGS if flags is not None and flag not in flags]
    if missing:
        return (f"this x86-64 processor lacks {' and '.join(missing)}: runs here repeat on this machine, but their "
                f"last bits (and so, in traffic, their trajectories) may differ from an x86-64-v3 machine's")
    return None


def warn_once() -> str | None:
    """Log :func:`caveat` for this machine once per process (a batch worker says it once, not per run)."""
    global _warned
    reason = caveat(flags=cpu_flags())
    if reason is not None and not _warned:
        _warned = True
        logger.warning("reproducibility: %s (docs/reproducibility.md)", reason)
    return reason
