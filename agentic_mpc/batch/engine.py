"""The batch: plan, lock the output directory, run what is not yet done, write the summary, handle interrupts."""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from agentic_mpc.batch.executors import connect_to_dask, run_locally, run_on_dask
from agentic_mpc.batch.planning import (
    BatchInputError,
    BatchJob,
    BatchSpec,
    Runner,
    plan_batch,
    resolve_runner,
    runner_reference,
)
from agentic_mpc.batch.progress import ProgressBar
from agentic_mpc.batch.records import BatchSummary

LOCK_FILE = ".batch.lock"


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


def run_batch(spec: BatchSpec, runner: Runner | str | None = None, progress: bool = True,
              jobs: list[BatchJob] | None = None) -> BatchResult:
    """Run every job of ``spec`` not yet finished; the package docstring says what is guaranteed.

    ``jobs``: run these instead of planning them from ``spec.files`` (``spec`` still gives the workers, the
    output directory and the executor). ``runner`` is the run function
    (``run_to_directory(scenario_file, variant, seed, out_dir) -> summary row``) or its ``module:function``;
    default :data:`DEFAULT_RUNNER`. Raises :class:`BatchInputError` before any
    run starts if the input is bad. Ctrl-C (or SIGTERM) stops the runs in flight and returns ``interrupted``.
    """
    runner_ref = runner_reference(runner)
    if jobs is None:
        all_jobs = plan_batch(spec, runner_ref)
    else:  # planned by the caller (``agentic-mpc lampilot``: one job per case file)
        if spec.executor == "process":
            resolve_runner(runner_ref)
        all_jobs = sorted(jobs)
    client = connect_to_dask(spec.scheduler) if spec.executor == "dask" else None
    spec.out_dir.mkdir(parents=True, exist_ok=True)
    with _Lock(spec.out_dir), _interrupt_on_sigterm(), contextlib.closing(client) if client else contextlib.nullcontext():
        summary = BatchSummary(spec.out_dir, all_jobs)
        todo = [job for job in all_jobs if not job.is_done_by(summary.records.get(job))]
        bar = ProgressBar(len(all_jobs), len(all_jobs) - len(todo), enabled=progress)
        bar.draw(force=True)
        interrupted = False
        try:
            if client is not None:
                run_on_dask(client, todo, runner_ref, spec, summary, bar)
            else:
                run_locally(todo, runner_ref, spec, summary, bar)
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
    # a parent may have started us with Ctrl-C blocked or ignored (a signal mask and SIG_IGN both survive
    # exec): a batch must stop on it
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
