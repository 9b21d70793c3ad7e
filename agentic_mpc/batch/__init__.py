"""Batches: every (scenario file x variant x seed) run, each in a fresh process, resumable.

libsumo keeps one simulation per process, so every run is a fresh ``python -m agentic_mpc.batch``
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

Modules: ``planning`` (spec, jobs, run function), ``records`` (per-run records, the summary), ``worker``
(one run in its process), ``launch`` (starting and stopping run processes), ``executors`` (local pool,
Dask), ``progress`` (the bar), ``engine`` (:func:`run_batch`).
"""

from agentic_mpc.batch.engine import BatchResult, run_batch
from agentic_mpc.batch.planning import (
    DEFAULT_RUNNER,
    BatchInputError,
    BatchJob,
    BatchSpec,
    Runner,
    default_workers,
    plan_batch,
    resolve_runner,
    runner_reference,
)
from agentic_mpc.batch.progress import ProgressBar

__all__ = [
    "DEFAULT_RUNNER", "BatchInputError", "BatchJob", "BatchResult", "BatchSpec", "ProgressBar", "Runner",
    "default_workers", "plan_batch", "resolve_runner", "run_batch", "runner_reference",
]
