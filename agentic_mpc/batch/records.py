"""Per-run records: one-row CSV files written atomically; a run directory holds a complete record.

A run works in a staging directory (a dot-name next to its run directory) and becomes the run directory by
one rename once its ``summary.csv`` is written. The batch's own ``summary.csv`` is rebuilt from the records.
A record is read back with the run directory's one reader (:mod:`agentic_mpc.run.reader`).
"""

from __future__ import annotations

import csv
import io
import os
import shutil
import time
import uuid
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from agentic_mpc.batch.planning import IDENTITY, PROVENANCE, BatchJob
from agentic_mpc.run.files import SUMMARY as RUN_SUMMARY
from agentic_mpc.run.reader import RunDirectory

WORKER_LOG = "worker.log"
_SUMMARY_EVERY_S = 1.0


def as_text(value: Any) -> str:
    return "" if value is None else str(value)


def error_line(error: BaseException) -> str:
    """An error as one line: ``ValueError: what went wrong``."""
    text = " ".join(str(error).split())
    return f"{type(error).__name__}: {text}" if text else type(error).__name__


def write_rows_atomically(path: Path, rows: list[Mapping[str, Any]], columns: list[str] | None = None) -> None:
    """CSV via a temp file in the same directory and a rename, so readers never see half a file."""
    if columns is None:
        columns = summary_columns(rows)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({key: as_text(row.get(key)) for key in columns})
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
    """The run's one-row summary, or None if the directory holds no complete record (a row with a status)."""
    row = RunDirectory(run_dir).summary()
    return row if row is not None and row.get("status") else None


def record_run(record: Mapping[str, Any], staging: Path, final: Path) -> None:
    """Write ``record`` into ``staging``, drop an empty ``worker.log`` and make it the run directory ``final``."""
    write_rows_atomically(staging / RUN_SUMMARY, [record])
    drop_if_empty(staging / WORKER_LOG)
    finalize_run(staging, final)


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


def drop_if_empty(path: Path) -> None:
    try:
        if path.stat().st_size == 0:
            path.unlink()
    except OSError:
        pass


class BatchSummary:
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
