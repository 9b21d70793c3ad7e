"""The agent's latency on LaMPilot cases, from the runs' transcripts: wall seconds from the command to the
agent's first tool call and to the end of its step (the last event of the step), with completion per group.

    .venv/bin/python benchmarks/lampilot_latency.py OUT...     # OUT: directories of agentic-mpc lampilot

Prints one JSON object per OUT: cases, completion % per group, and the median and p95 latencies.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd


def latencies(transcript: Path) -> tuple[float | None, float | None]:
    start = first_call = last = None
    for line in transcript.read_text(encoding="utf-8").splitlines():
        record = json.loads(line)
        if record.get("event") == "message" and record.get("role") == "user" and start is None:
            start = record["wall_time_s"]
        elif start is not None:
            last = record["wall_time_s"]
            if record.get("event") == "tool_call" and first_call is None:
                first_call = record["wall_time_s"]
    if start is None:
        return None, None
    return (None if first_call is None else first_call - start), (None if last is None else last - start)


def summarise(out: Path) -> dict:
    cases = pd.read_csv(out / "cases.csv")
    cases = cases[cases["status"] == "ok"]
    to_call, to_end = [], []
    for run_dir in cases["run_dir"]:
        call_s, end_s = latencies(Path(run_dir) / "transcript.jsonl")
        to_call += [call_s] if call_s is not None else []
        to_end += [end_s] if end_s is not None else []

    def stats(values: list[float]) -> dict:
        return {"median_s": round(float(np.median(values)), 1), "p95_s": round(float(np.percentile(values, 95)), 1)} \
            if values else {}

    groups = cases.groupby("group")["success"].agg(["size", "mean"])
    return {"out": str(out), "cases": len(cases), "completion_pct": round(100 * cases["success"].mean(), 1),
            "by_group": {g: {"cases": int(r["size"]), "completion_pct": round(100 * r["mean"], 1)}
                         for g, r in groups.iterrows()},
            "cases_with_a_call": len(to_call), "to_first_call": stats(to_call), "to_step_end": stats(to_end)}


if __name__ == "__main__":
    for argument in sys.argv[1:]:
        print(json.dumps(summarise(Path(argument))))
