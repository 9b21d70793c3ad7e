"""Batches: every (scenario file x variant x seed) run, each in a fresh process, resumable.

libsumo keeps one simulation per process, so every run is a fresh ``python -m agentic_mpc.scenario.batch``
subprocess (started by the batch itself, or by a Dask task on a cluster worker). A run works in a staging
directory and becomes ``runs/<scenario>/<variant>/seed-<N>/`` by one rename once its ``summary.csv`` (one
row, written with temp file + rename) is complete: a run directory exists if and only if its record is
complete. Runs recorded as ``ok`` are skipped by the next invocation; ``failed`` (the run function raised)
and ``crashed`` (the process died) runs are recorded with their error and retried next time. A record
names the SHA-256 of the scenario file it ran: after the file changes, its old runs are not results of it
and run again. The batch's ``summary.csv`` (the runs of this invocation's files x variants x seeds) is
rebuilt from the per-run summaries, so killing the batch loses nothing that finished.

Run processes start in their own session: Ctrl-C reaches only the batch, which stops them, writes the
summary of what finished and returns. If the batch is killed outright, runs in flight finish on their own
and keep their results.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import importlib
import io
import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
import time
import traceback
import uuid
from collections import deque
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, Literal

DEFAULT_RUNNER = "agentic_mpc.scenario.runner:run_to_directory"
"""The run function, as ``module:function``: it must be importable in the run processes."""

RUN_SUMMARY = "summary.csv"
WORKER_LOG = "worker.log"
LOCK_FILE = ".batch.lock"
IDENTITY = ("scenario", "variant", "seed", "status", "error")
"""The first columns of every summary, in this order; the run function's own columns follow."""
PROVENANCE = "scenario_sha256"
"""The last column: which version of the scenario file the run ran (first 16 hex digits)."""
_SAFE_NAME = r"^[A-Za-z0-9_.-]+$"
_STOP_GRACE_S = 5.0
_POLL_S = 0.05
_SUMMARY_EVERY_S = 1.0
DASK_CONNECT_TIMEOUT_S = 10.0

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


@dataclass
class BatchResult:
    """What a batch did: the summary's rows (as written, text) and what happened in this invocation."""

    summary_path: Path
    rows: list[dict[str, str]]
    total: int
    skipped: int
    """Runs already finished (``ok``) by an earlier invocation."""
    ran: int
    """Runs that finished (in any status) in this invocation."""
    interrupted: bool = False

    def count(self, status: str) -> int:
        return sum(row["status"] == status for row in self.rows)

    @property
    def all_ok(self) -> bool:
        return not self.interrupted and len(self.rows) == self.total and self.count("ok") == self.total


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

    from agentic_mpc.scenario.yaml_source import ScenarioFileError

    from agentic_mpc.scenario.schema import load_scenario  # heavy (SUMO bindings): only where planning happens

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


# ---------------------------------------------------------------------------------------------------------
# per-run records: one-row CSV files written atomically; a run directory holds a complete record


def _text(value: Any) -> str:
    return "" if value is None else str(value)


def write_rows_atomically(path: Path, rows: list[Mapping[str, Any]], columns: list[str] | None = None) -> None:
    """CSV via a temp file in the same directory and a rename, so readers never see half a file."""
    if columns is None:
        columns = summary_columns(rows)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({key: _text(row.get(key)) for key in columns})
    temp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    with open(temp, "w", encoding="utf-8", newline="") as handle:
        handle.write(buffer.getvalue())
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(temp, path)


def summary_columns(rows: list[Mapping[str, Any]]) -> list[str]:
    """Identity first, provenance last, the run function's columns in between (as first seen)."""
    extra = dict.fromkeys(key for row in rows for key in row if key not in (*IDENTITY, PROVENANCE))
    return [*IDENTITY, *extra, PROVENANCE]


def read_record(run_dir: Path) -> dict[str, str] | None:
    """The run's one-row summary, or None if the directory holds no complete record."""
    try:
        with open(run_dir / RUN_SUMMARY, encoding="utf-8", newline="") as handle:
            rows = list(csv.DictReader(handle))
    except (OSError, csv.Error, UnicodeDecodeError):
        return None
    return rows[0] if len(rows) == 1 and rows[0].get("status") else None


def _one_line(error: BaseException) -> str:
    text = " ".join(str(error).split())
    return f"{type(error).__name__}: {text}" if text else type(error).__name__


def finalize_run(staging: Path, final: Path) -> None:
    """Make ``staging`` the run directory ``final`` by renames; a finished (ok) result of the same scenario
    file is never replaced."""
    final.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.rename(staging, final)
        return
    except OSError:
        if not final.exists():
            raise
    existing, new = read_record(final), read_record(staging) or {}
    if existing is not None and existing["status"] == "ok" and existing.get(PROVENANCE) == new.get(PROVENANCE):
        shutil.rmtree(staging, ignore_errors=True)  # another process finished this run first
        return
    trash = final.with_name(f".{final.name}.{uuid.uuid4().hex}.old")
    os.rename(final, trash)
    os.rename(staging, final)
    shutil.rmtree(trash, ignore_errors=True)


def new_staging_dir(final: Path) -> Path:
    """A unique sibling of ``final``: a dot-name, so it is never mistaken for a run directory."""
    final.parent.mkdir(parents=True, exist_ok=True)
    for stale in final.parent.glob(f".{final.name}.*.tmp"):  # from a batch that was killed
        shutil.rmtree(stale, ignore_errors=True)
    staging = final.with_name(f".{final.name}.{uuid.uuid4().hex}.tmp")
    staging.mkdir()
    return staging


# ---------------------------------------------------------------------------------------------------------
# one run in a fresh process


def _worker_main(argv: list[str]) -> int:
    """Entry point of a run process: run, write the record (ok or failed), finalize. Exit 0 when recorded."""
    runner_ref, scenario_file, digest, scenario, variant, seed_text, staging_text, final_text = argv
    job = BatchJob(scenario, variant, int(seed_text), Path(scenario_file), digest)
    staging, final = Path(staging_text), Path(final_text)
    try:
        row = resolve_runner(runner_ref)(job.scenario_file, job.variant, job.seed, staging)
        if not isinstance(row, Mapping):
            raise TypeError(f"the run function returned {type(row).__name__}, expected a dict (the summary row)")
        record = job.record(_text(row.get("status")) or "ok", _text(row.get("error")), row)
    except (Exception, SystemExit) as error:  # noqa: BLE001 - any failure of the run is its record
        traceback.print_exc()  # into worker.log, next to the record
        record = job.record("failed", _one_line(error))
    write_rows_atomically(staging / RUN_SUMMARY, [record])
    _drop_if_empty(staging / WORKER_LOG)
    finalize_run(staging, final)
    return 0


def _drop_if_empty(path: Path) -> None:
    try:
        if path.stat().st_size == 0:
            path.unlink()
    except OSError:
        pass


def _child_environment() -> dict[str, str]:
    # the run process must import what this one can (e.g. a run function next to the caller's code)
    paths = [p for p in sys.path if p and os.path.isdir(p)]
    return {**os.environ, "PYTHONPATH": os.pathsep.join(paths)}


@dataclass
class _RunningJob:
    job: BatchJob
    process: subprocess.Popen | _ForkedRun
    staging: Path
    final: Path
    log: IO[bytes]


WARM_START_MODULE = "agentic_mpc.scenario.warm_start"
_warm_context: Any = None


def _forkserver() -> Any:
    """The fork server runs are forked from: it has imported everything once (see ``warm_start``)."""
    global _warm_context
    if _warm_context is None:
        from multiprocessing import forkserver

        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload([WARM_START_MODULE])
        # The server and its resource tracker outlive a killed batch while runs are in flight: they must not
        # hold the batch's stdout/stderr open (whoever reads them would wait for the runs to end).
        with _stdio_on_devnull():
            forkserver.ensure_running()
        _warm_context = context
    return _warm_context


@contextlib.contextmanager
def _stdio_on_devnull() -> Iterator[None]:
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(fd) for fd in (0, 1, 2)]
    null = os.open(os.devnull, os.O_RDWR)
    try:
        for fd in (0, 1, 2):
            os.dup2(null, fd)
        yield
    finally:
        for fd, copy in zip((0, 1, 2), saved):
            os.dup2(copy, fd)
            os.close(copy)
        os.close(null)


class _ForkedRun:
    """A run forked from the warm fork server, with the ``subprocess.Popen`` methods the batch uses."""

    def __init__(self, process: Any) -> None:
        self._process = process

    @property
    def pid(self) -> int:
        return self._process.pid

    @property
    def returncode(self) -> int | None:
        return self._process.exitcode

    def poll(self) -> int | None:
        return self._process.exitcode

    def wait(self, timeout: float | None = None) -> int:
        self._process.join(timeout)
        if self._process.exitcode is None:
            raise subprocess.TimeoutExpired("forked run", timeout or 0.0)
        return self._process.exitcode


def _forked_main(argv: list[str], log_path: str, environment: dict[str, str], cwd: str, path: list[str]) -> None:
    """A forked run: own session (Ctrl-C reaches only the batch), output into worker.log, then run.

    The fork server keeps the environment, directory and import path it started with; a run must see the
    batch's current ones (an API key set since, a run function next to the caller's code).
    """
    os.setsid()
    os.environ.clear()
    os.environ.update(environment)
    os.chdir(cwd)
    sys.path[:] = path
    log = os.open(log_path, os.O_WRONLY | os.O_APPEND)
    os.dup2(log, 1)
    os.dup2(log, 2)
    os.dup2(os.open(os.devnull, os.O_RDONLY), 0)
    code = _worker_main(argv)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def _worker_argv(job: BatchJob, runner_ref: str, staging: Path, final: Path) -> list[str]:
    return [runner_ref, str(job.scenario_file), job.scenario_sha256, job.scenario, job.variant, str(job.seed),
            str(staging), str(final)]


def start_run(job: BatchJob, runner_ref: str, staging: Path, final: Path, warm: bool = False) -> _RunningJob:
    """Start one run process; its output goes to ``worker.log`` in the run directory.

    ``warm``: fork it from the fork server (about 1.7 s faster to start); otherwise a fresh interpreter,
    which is what Dask workers need (their daemonic processes cannot have multiprocessing children).
    """
    log = open(staging / WORKER_LOG, "wb")
    argv = _worker_argv(job, runner_ref, staging, final)
    if warm:
        context = (argv, str(staging / WORKER_LOG), dict(os.environ), os.getcwd(), list(sys.path))
        process = _forkserver().Process(target=_forked_main, args=context, daemon=False)
        process.start()
        return _RunningJob(job, _ForkedRun(process), staging, final, log)
    command = [sys.executable, "-m", "agentic_mpc.scenario.batch", *argv]
    # own session: Ctrl-C at the terminal reaches the batch only, which decides what to stop
    popen = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
                             env=_child_environment(), start_new_session=True)
    return _RunningJob(job, popen, staging, final, log)


def finish_run(running: _RunningJob) -> dict[str, str]:
    """After the process exited: its record, or a ``crashed`` record if it died before writing one."""
    running.log.close()
    code = running.process.returncode
    if not running.staging.exists():  # the process renamed it: its record is complete
        record = read_record(running.final)
        if record is not None:
            return record
        running.staging.mkdir(parents=True)
    if code is not None and code < 0:
        try:
            cause = f"killed by signal {signal.Signals(-code).name}"
        except ValueError:
            cause = f"killed by signal {-code}"
    else:
        cause = f"exited with code {code}"
    last = _last_line(running.staging / WORKER_LOG)
    error = f"run process {cause}" + (f"; last output: {last}" if last else "")
    record = running.job.record("crashed", error)
    write_rows_atomically(running.staging / RUN_SUMMARY, [record])
    _drop_if_empty(running.staging / WORKER_LOG)
    finalize_run(running.staging, running.final)
    return read_record(running.final) or {key: _text(value) for key, value in record.items()}


def _last_line(path: Path, max_chars: int = 300) -> str:
    try:
        with open(path, "rb") as handle:
            handle.seek(max(0, path.stat().st_size - 4096))
            lines = [line.strip() for line in handle.read().decode("utf-8", "replace").splitlines() if line.strip()]
    except OSError:
        return ""
    return lines[-1][:max_chars] if lines else ""


def stop_run(running: _RunningJob) -> None:
    """Stop a run that will not be recorded (the batch was interrupted) and remove its staging directory."""
    if running.process.poll() is None:
        _signal_group(running.process, signal.SIGTERM)
        try:
            running.process.wait(_STOP_GRACE_S)
        except subprocess.TimeoutExpired:
            _signal_group(running.process, signal.SIGKILL)
            running.process.wait()
    running.log.close()
    shutil.rmtree(running.staging, ignore_errors=True)


def _signal_group(process: subprocess.Popen | _ForkedRun, signum: int) -> None:
    # the run process leads its own session: signal the group, so anything it started stops too
    try:
        os.killpg(process.pid, signum)
    except (ProcessLookupError, PermissionError):
        pass


def run_isolated(job: BatchJob, runner_ref: str) -> dict[str, Any]:
    """A Dask task: one run in a fresh process on the worker; returns its record and files (no shared disk needed)."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="agentic-mpc-run-") as temp:
        final = Path(temp) / "run"
        running = start_run(job, runner_ref, new_staging_dir(final), final)
        running.process.wait()
        record = finish_run(running)
        files = {str(p.relative_to(final)): p.read_bytes() for p in sorted(final.rglob("*")) if p.is_file()}
    return {"record": record, "files": files}


# ---------------------------------------------------------------------------------------------------------
# the batch


class ProgressBar:
    """``[####....] 12/40  ok 10  failed 1  crashed 1  0:32 elapsed  ETA 1:10``: redrawn in place on a
    terminal, one line per finished run otherwise (logs)."""

    def __init__(self, total: int, done: int, stream: IO[str] | None = None, enabled: bool = True) -> None:
        self.total, self.done_before = total, done
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.tty = enabled and self.stream.isatty()
        self.started = time.monotonic()
        self.counts = {"ok": 0, "failed": 0, "crashed": 0}
        self.ran = 0
        self._last_draw = 0.0

    def add(self, status: str) -> None:
        self.ran += 1
        self.counts[status] = self.counts.get(status, 0) + 1
        self.draw(force=True)

    def line(self) -> str:
        done = self.done_before + self.ran
        elapsed = time.monotonic() - self.started
        remaining = self.total - done
        eta = _clock(elapsed / self.ran * remaining) if self.ran and remaining else ("0:00" if not remaining else "--:--")
        filled = round(28 * done / self.total) if self.total else 28
        skipped = f" ({self.done_before} already done)" if self.done_before else ""
        counts = "  ".join(f"{status} {n}" for status, n in self.counts.items())
        return (f"[{'#' * filled}{'.' * (28 - filled)}] {done}/{self.total}{skipped}  {counts}  "
                f"{_clock(elapsed)} elapsed  ETA {eta}")

    def draw(self, force: bool = False) -> None:
        if not self.enabled or (not force and (not self.tty or time.monotonic() - self._last_draw < 0.5)):
            return
        self._last_draw = time.monotonic()
        self.stream.write(f"\r{self.line()}\x1b[K" if self.tty else f"{self.line()}\n")
        self.stream.flush()

    def close(self) -> None:
        if self.tty:
            self.draw(force=True)
            self.stream.write("\n")
            self.stream.flush()


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    hours, rest = divmod(seconds, 3600)
    return f"{hours}:{rest // 60:02d}:{rest % 60:02d}" if hours else f"{rest // 60}:{rest % 60:02d}"


class _Summary:
    """The records of the batch's jobs, written to ``summary.csv`` (sorted) as they arrive, at most once a second."""

    def __init__(self, out_dir: Path, jobs: list[BatchJob]) -> None:
        self.path = out_dir / "summary.csv"
        self.out_dir, self.jobs = out_dir, jobs
        self.records: dict[BatchJob, dict[str, str]] = {}
        self.reread()
        self._written = 0.0

    def reread(self) -> None:
        """The records on disk: the truth, whatever happened to the process that wrote them."""
        records = {job: read_record(job.run_dir(self.out_dir)) for job in self.jobs}
        self.records = {job: r for job, r in records.items() if r is not None and job.is_recorded_by(r)}

    def add(self, job: BatchJob, record: dict[str, str]) -> None:
        self.records[job] = record
        if time.monotonic() - self._written >= _SUMMARY_EVERY_S:
            self.write()

    def rows(self) -> list[dict[str, str]]:
        return [self.records[job] for job in self.jobs if job in self.records]

    def write(self) -> list[dict[str, str]]:
        """Write ``summary.csv``; returns its rows as written (every column in every row)."""
        rows = self.rows()
        columns = summary_columns(rows)
        write_rows_atomically(self.path, rows, columns)
        self._written = time.monotonic()
        return [{key: row.get(key, "") for key in columns} for row in rows]


class _Lock:
    """One batch per output directory at a time (two would run the same jobs twice)."""

    def __init__(self, out_dir: Path) -> None:
        self.path = out_dir / LOCK_FILE
        self.handle: IO[str] | None = None

    def __enter__(self) -> _Lock:
        try:
            import fcntl
        except ImportError:  # not POSIX: no lock
            return self
        self.handle = open(self.path, "a")
        try:
            fcntl.flock(self.handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self.handle.close()
            raise BatchInputError([f"--out {self.path.parent}: another batch is running in this directory"]) from None
        return self

    def __exit__(self, *exc: object) -> None:
        if self.handle is not None:
            self.handle.close()


def run_batch(spec: BatchSpec, runner: Runner | str | None = None, progress: bool = True) -> BatchResult:
    """Run every job of ``spec`` not yet finished; see the module docstring for what is guaranteed.

    ``runner`` is the run function (``run_to_directory(scenario_file, variant, seed, out_dir) -> summary row``)
    or its ``module:function``; default :data:`DEFAULT_RUNNER`. Raises :class:`BatchInputError` before any
    run starts if the input is bad. Ctrl-C (or SIGTERM) stops the runs in flight and returns ``interrupted``.
    """
    runner_ref = runner_reference(runner)
    all_jobs = plan_batch(spec, runner_ref)
    client = _connect_to_dask(spec.scheduler) if spec.executor == "dask" else None
    spec.out_dir.mkdir(parents=True, exist_ok=True)
    with _Lock(spec.out_dir), _interrupt_on_sigterm(), contextlib.closing(client) if client else contextlib.nullcontext():
        summary = _Summary(spec.out_dir, all_jobs)
        todo = [job for job in all_jobs if not job.is_done_by(summary.records.get(job))]
        bar = ProgressBar(len(all_jobs), len(all_jobs) - len(todo), enabled=progress)
        bar.draw(force=True)
        interrupted = False
        try:
            if client is not None:
                _run_on_dask(client, todo, runner_ref, spec, summary, bar)
            else:
                _run_locally(todo, runner_ref, spec, summary, bar)
        except KeyboardInterrupt:
            interrupted = True
        finally:
            bar.close()
            summary.reread()  # also what finished while an interrupt was being handled
            rows = summary.write()
    return BatchResult(summary.path, rows, len(all_jobs), len(all_jobs) - len(todo), bar.ran, interrupted)


@contextlib.contextmanager
def _interrupt_on_sigterm() -> Iterator[None]:
    """SIGTERM (a job scheduler, ``kill``) ends the batch like Ctrl-C: runs stopped, summary written."""

    def interrupt(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGTERM, interrupt)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _run_locally(todo: list[BatchJob], runner_ref: str, spec: BatchSpec, summary: _Summary, bar: ProgressBar) -> None:
    pending, running = deque(todo), []
    try:
        while pending or running:
            while pending and len(running) < spec.workers:
                job = pending.popleft()
                final = job.run_dir(spec.out_dir)
                running.append(start_run(job, runner_ref, new_staging_dir(final), final, warm=True))
            time.sleep(_POLL_S)
            for run in [r for r in running if r.process.poll() is not None]:
                running.remove(run)
                record = finish_run(run)
                summary.add(run.job, record)
                bar.add(record["status"])
            bar.draw()
    except BaseException:
        for run in running:
            stop_run(run)
        raise


def _connect_to_dask(scheduler: str | None) -> Any:
    from distributed import Client

    try:
        return Client(scheduler, timeout=f"{DASK_CONNECT_TIMEOUT_S}s")
    except (OSError, TimeoutError, ValueError) as error:
        raise BatchInputError([f"--scheduler {scheduler}: cannot reach the Dask scheduler: {error}"]) from error


def _run_on_dask(client: Any, todo: list[BatchJob], runner_ref: str, spec: BatchSpec, summary: _Summary,
                 bar: ProgressBar) -> None:
    from distributed import as_completed

    futures: dict[Any, BatchJob] = {}
    try:
        for job in todo:
            # pure=False: the same job submitted again (a retry) must run again, not reuse a cached result
            futures[client.submit(run_isolated, job, runner_ref, pure=False, key=f"run-{job.label()}-{uuid.uuid4().hex}")] = job
        for future in as_completed(futures):
            job = futures[future]
            final = job.run_dir(spec.out_dir)
            staging = new_staging_dir(final)
            try:
                result = future.result()
            except Exception as error:  # noqa: BLE001 - e.g. KilledWorker: the worker itself died
                record: dict[str, Any] = job.record("crashed", f"Dask: {_one_line(error)}")
                write_rows_atomically(staging / RUN_SUMMARY, [record])
            else:
                for relative, content in result["files"].items():
                    target = staging / relative
                    target.parent.mkdir(parents=True, exist_ok=True)
                    target.write_bytes(content)
            finalize_run(staging, final)
            record = read_record(final) or {}
            summary.add(job, record)
            bar.add(record.get("status", "crashed"))
    finally:
        # on Ctrl-C, runs already on a worker finish there but are not recorded (Dask cannot stop a running task)
        client.cancel(list(futures))


if __name__ == "__main__":
    sys.exit(_worker_main(sys.argv[1:]))
