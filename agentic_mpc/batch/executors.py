"""Where runs run: a pool of local run processes, or tasks on a Dask cluster (each a fresh process there)."""

from __future__ import annotations

import time
import uuid
from collections import deque
from pathlib import Path
from typing import Any

from agentic_mpc.batch.launch import finish_run, start_run, stop_run
from agentic_mpc.batch.planning import BatchInputError, BatchJob, BatchSpec
from agentic_mpc.batch.progress import ProgressBar
from agentic_mpc.batch.records import (
    RUN_SUMMARY,
    BatchSummary,
    error_line,
    finalize_run,
    new_staging_dir,
    read_record,
    write_rows_atomically,
)

_POLL_S = 0.05
DASK_CONNECT_TIMEOUT_S = 10.0


def run_locally(todo: list[BatchJob], runner_ref: str, spec: BatchSpec, summary: BatchSummary,
                bar: ProgressBar) -> None:
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


# ---------------------------------------------------------------------------------------------------------
# Dask


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


def connect_to_dask(scheduler: str | None) -> Any:
    from distributed import Client

    try:
        return Client(scheduler, timeout=f"{DASK_CONNECT_TIMEOUT_S}s")
    except (OSError, TimeoutError, ValueError) as error:
        raise BatchInputError([f"--scheduler {scheduler}: cannot reach the Dask scheduler: {error}"]) from error


def run_on_dask(client: Any, todo: list[BatchJob], runner_ref: str, spec: BatchSpec, summary: BatchSummary,
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
                record: dict[str, Any] = job.record("crashed", f"Dask: {error_line(error)}")
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
