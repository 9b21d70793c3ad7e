"""What a batch runs: the spec, its jobs (checked before any run starts) and the run function by reference."""

from __future__ import annotations

import hashlib
import importlib
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

DEFAULT_RUNNER = "agentic_mpc.scenario.runner:run_to_directory"
"""The run function, as ``module:function``: it must be importable in the run processes."""

IDENTITY = ("scenario", "variant", "seed", "status", "error")
"""The first columns of every summary, in this order; the run function's own columns follow."""
PROVENANCE = "scenario_sha256"
"""The last column: which version of the scenario file the run ran (first 16 hex digits)."""
_SAFE_NAME = r"^[A-Za-z0-9_.-]+$"

Runner = Callable[[Path, str, int, Path], Mapping[str, Any]]
Executor = Literal["process", "dask"]


class BatchInputError(ValueError):
    """A batch that cannot start; lists every problem (file, variant or argument) found before any run."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        super().__init__("\n".join(problems))


def default_workers() -> int:
    """The cores this process may use (affinity-aware where the OS tells)."""
    if hasattr(os, "process_cpu_count"):
        return os.process_cpu_count() or 1
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0)) or 1
    return os.cpu_count() or 1


@dataclass(frozen=True)
class BatchSpec:
    """What a batch runs and where; validated on construction (every problem at once)."""

    files: tuple[Path, ...]
    trials: int
    variants: tuple[str, ...] | None = None
    """Variants to run in every file; None runs each file's own variants (``base`` if it has none)."""
    first_seed: int = 0
    workers: int = field(default_factory=default_workers)
    out_dir: Path = Path("out/batch")
    executor: Executor = "process"
    scheduler: str | None = None
    """Dask scheduler address (``tcp://host:8786``); only with ``executor="dask"``."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "files", tuple(Path(f) for f in self.files))
        object.__setattr__(self, "out_dir", Path(self.out_dir))
        if self.variants is not None:
            object.__setattr__(self, "variants", tuple(dict.fromkeys(self.variants)))
        problems = []
        if not self.files:
            problems.append("no scenario file given")
        if not isinstance(self.trials, int) or self.trials < 1:
            problems.append(f"--trials must be at least 1, got {self.trials}")
        if not isinstance(self.first_seed, int) or self.first_seed < 0:
            problems.append(f"--first-seed must be 0 or more (seeds are non-negative), got {self.first_seed}")
        if not isinstance(self.workers, int) or self.workers < 1:
            problems.append(f"--workers must be at least 1, got {self.workers}")
        if self.variants is not None and not self.variants:
            problems.append("--variants given without any variant")
        if self.executor not in ("process", "dask"):
            problems.append(f"--executor must be 'process' or 'dask', got {self.executor!r}")
        elif self.executor == "dask" and not self.scheduler:
            problems.append("--executor dask needs --scheduler ADDRESS (e.g. tcp://scheduler:8786)")
        elif self.executor == "process" and self.scheduler:
            problems.append("--scheduler is only used with --executor dask")
        if problems:
            raise BatchInputError(problems)

    @property
    def seeds(self) -> range:
        return range(self.first_seed, self.first_seed + self.trials)


@dataclass(frozen=True, order=True)
class BatchJob:
    """One simulation. Ordered by (scenario, variant, seed): the order of the summary."""

    scenario: str
    variant: str
    seed: int
    scenario_file: Path = field(compare=False)
    scenario_sha256: str = field(compare=False, default="")

    def run_dir(self, out_dir: Path) -> Path:
        return out_dir / "runs" / self.scenario / self.variant / f"seed-{self.seed}"

    def identity(self) -> dict[str, Any]:
        return {"scenario": self.scenario, "variant": self.variant, "seed": self.seed}

    def record(self, status: str, error: str, row: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """This run's summary row: identity, status, error, the run function's columns, provenance."""
        extra = {key: value for key, value in (row or {}).items() if key not in (*IDENTITY, PROVENANCE)}
        return {**self.identity(), "status": status, "error": error, **extra, PROVENANCE: self.scenario_sha256}

    def is_done_by(self, record: Mapping[str, str] | None) -> bool:
        """Whether ``record`` is a finished run of this job (ok, on this version of the scenario file)."""
        return record is not None and record.get("status") == "ok" and self.is_recorded_by(record)

    def is_recorded_by(self, record: Mapping[str, str]) -> bool:
        return record.get(PROVENANCE, "") == self.scenario_sha256

    def label(self) -> str:
        return f"{self.scenario}/{self.variant}/seed-{self.seed}"


# ---------------------------------------------------------------------------------------------------------
# the run function, by reference: run processes (maybe on other machines) import it themselves


def runner_reference(runner: Runner | str | None) -> str:
    """``module:function`` of a run function; refuses what another process could not import."""
    if runner is None:
        return DEFAULT_RUNNER
    if isinstance(runner, str):
        return runner
    module, name = getattr(runner, "__module__", None), getattr(runner, "__qualname__", "")
    reference = f"{module}:{name}"
    if module in (None, "__main__") or "<" in name:
        raise BatchInputError([f"the run function {reference} must be a module-level function of an importable module"])
    return reference


def resolve_runner(reference: str) -> Runner:
    module_name, _, name = reference.partition(":")
    if not module_name or not name:
        raise BatchInputError([f"--runner {reference!r}: expected module:function"])
    try:
        target: Any = importlib.import_module(module_name)
        for part in name.split("."):
            target = getattr(target, part)
    except (ImportError, AttributeError) as error:
        raise BatchInputError([f"cannot import the run function {reference}: {error}"]) from error
    if not callable(target):
        raise BatchInputError([f"the run function {reference} is not callable"])
    return target


# ---------------------------------------------------------------------------------------------------------
# planning: every check before any simulation starts


def plan_batch(spec: BatchSpec, runner: Runner | str | None = None) -> list[BatchJob]:
    """Every job of ``spec``, sorted; raises :class:`BatchInputError` listing every problem found."""
    import re

    from agentic_mpc.scenario.schema import load_scenario  # heavy (SUMO bindings): only where planning happens
    from agentic_mpc.scenario.yaml_source import ScenarioFileError

    problems: list[str] = []
    jobs: list[BatchJob] = []
    names: dict[str, Path] = {}
    for file in spec.files:
        try:
            scenario_file = load_scenario(file)
        except ScenarioFileError as error:
            problems.extend(error.problems)
            continue
        name = scenario_file.base.name
        resolved = scenario_file.path.resolve()
        digest = hashlib.sha256(resolved.read_bytes()).hexdigest()[:16]
        if name in names:
            other = names[name]
            problems.append(
                f"{file}: listed twice" if other == resolved
                else f"{file}: scenario name {name!r} is also the name of {other}; runs/{name}/ would mix them"
            )
            continue
        names[name] = resolved
        available = scenario_file.variant_names
        wanted = list(spec.variants) if spec.variants is not None else available
        for variant in wanted:
            if variant != "base" and variant not in scenario_file.variants:
                problems.append(f"{file}: unknown variant {variant!r}; variants: {', '.join(available)}")
            elif not re.match(_SAFE_NAME, variant) or variant in (".", ".."):
                problems.append(f"{file}: variant name {variant!r} cannot be a directory name (use A-Z a-z 0-9 _ . -)")
            else:
                jobs.extend(BatchJob(name, variant, seed, resolved, digest) for seed in spec.seeds)
    if spec.out_dir.exists() and not spec.out_dir.is_dir():
        problems.append(f"--out {spec.out_dir}: exists and is not a directory")
    try:
        reference = runner_reference(runner)
        if spec.executor == "process":  # on Dask the workers import it; the client may not have it
            resolve_runner(reference)
    except BatchInputError as error:
        problems.extend(error.problems)
    if spec.executor == "dask":
        try:
            import distributed  # noqa: F401
        except ImportError:
            problems.append('--executor dask needs the optional dask extra: pip install "agentic-mpc[dask]"')
    if problems:
        raise BatchInputError(list(dict.fromkeys(problems)))
    return sorted(jobs)
