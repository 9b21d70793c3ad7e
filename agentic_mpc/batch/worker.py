"""One run, inside its run process: run the function, record the result (ok or failed), finalize.

A fresh interpreter gets here through ``python -m agentic_mpc.batch`` (see ``__main__.py``), a run forked
from the warm fork server through ``launch.start_run(..., warm=True)``.
"""

from __future__ import annotations

import traceback
from collections.abc import Mapping
from pathlib import Path

from agentic_mpc.batch.planning import BatchJob, resolve_runner
from agentic_mpc.batch.records import as_text, error_line, record_run


def worker_argv(job: BatchJob, runner_ref: str, staging: Path, final: Path) -> list[str]:
    """The arguments of :func:`worker_main` for one run."""
    return [runner_ref, str(job.scenario_file), job.scenario_sha256, job.scenario, job.variant, str(job.seed),
            str(staging), str(final)]


def worker_main(argv: list[str]) -> int:
    """Entry point of a run process: run, write the record (ok or failed), finalize. Exit 0 when recorded."""
    runner_ref, scenario_file, digest, scenario, variant, seed_text, staging_text, final_text = argv
    job = BatchJob(scenario, variant, int(seed_text), Path(scenario_file), digest)
    staging, final = Path(staging_text), Path(final_text)
    try:
        row = resolve_runner(runner_ref)(job.scenario_file, job.variant, job.seed, staging)
        if not isinstance(row, Mapping):
            raise TypeError(f"the run function returned {type(row).__name__}, expected a dict (the summary row)")
        record = job.record(as_text(row.get("status")) or "ok", as_text(row.get("error")), row)
    except (Exception, SystemExit) as error:  # noqa: BLE001 - any failure of the run is its record
        traceback.print_exc()  # into worker.log, next to the record
        record = job.record("failed", error_line(error))
    record_run(record, staging, final)
    return 0
