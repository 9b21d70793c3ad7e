"""``cases.csv`` and the LaMPilot table: completion %, collision % and mean driving score per task group, over
the highway tasks, and in total (a case whose scene cannot be built is listed with its reason and counted as a
failure in the total)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from agentic_mpc.lampilot.dataset import GROUPS, UNSUPPORTED_GROUPS

CASE_COLUMNS = ("task", "group", "case", "command", "seed", "status", "success", "collided", "score", "reason",
                "decided_at_s", "target", "min_ttc_s", "ttc_score", "speed_variance_score", "time_efficiency_score",
                "agent_tool_calls", "wall_s", "run_dir", "error")
GROUP_ORDER = tuple(dict.fromkeys(GROUPS.values()))
PUBLISHED = {"completion_pct": 92.7, "collision_pct": 0.9}
"""LaMPilot's abstract: GPT-4 with human feedback."""


def case_rows(summary_rows: list[dict[str, str]], out_dir: Path, unsupported: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per case: the batch's summary rows (a crashed run counts as a failure) and the cases of
    unsupported tasks, which were not run."""
    rows = []
    for row in summary_rows:
        ok = row.get("status") == "ok"
        rows.append({
            **{column: row.get(column, "") for column in CASE_COLUMNS},
            "task": row.get("task") or row["scenario"], "case": row.get("case") or row["variant"],
            "success": ok and row.get("success") == "True", "collided": ok and row.get("collided") == "True",
            "score": float(row["score"]) if ok and row.get("score") not in (None, "") else 0.0,
            "reason": row.get("reason") if ok else f"run {row.get('status')}: {row.get('error', '')}",
            "run_dir": str(out_dir / "runs" / row["scenario"] / row["variant"] / f"seed-{row['seed']}"),
        })
    return rows + unsupported


def group_table(rows: list[dict[str, Any]]) -> Any:  # -> pandas.DataFrame
    """Completion %, collision % and mean driving score per group, then the total."""
    import pandas as pd

    frame = pd.DataFrame(rows, columns=list(CASE_COLUMNS))
    frame["group"] = pd.Categorical(frame["group"], [g for g in GROUP_ORDER if g in set(frame["group"])])
    lines = []
    for group, part in frame.groupby("group", observed=True):
        lines.append(_line(str(group), part, supported=group not in UNSUPPORTED_GROUPS))
    supported = frame[~frame["group"].isin(UNSUPPORTED_GROUPS)]
    if len(supported) < len(frame):  # LaMPilot's highway tasks alone, then everything
        lines.append(_line("highway tasks", supported, supported=True))
    lines.append(_line("total", frame, supported=True))
    return pd.DataFrame(lines).set_index("group")


def _line(name: str, part: Any, supported: bool) -> dict[str, Any]:
    n = len(part)
    return {
        "group": name, "cases": n, "tasks": part["task"].nunique(),
        "completion_pct": round(100.0 * part["success"].astype(bool).mean(), 1) if n else float("nan"),
        "collision_pct": round(100.0 * part["collided"].astype(bool).mean(), 1) if n else float("nan"),
        "mean_score": round(part["score"].astype(float).mean(), 1) if n else float("nan"),
        "note": "" if supported else "not supported (needs junctions): counted as failures",
    }


def write_outputs(rows: list[dict[str, Any]], out_dir: Path) -> tuple[Path, Path, Any]:
    """``OUT/cases.csv`` and ``OUT/table.csv``; returns their paths and the table."""
    import pandas as pd

    cases_path, table_path = out_dir / "cases.csv", out_dir / "table.csv"
    pd.DataFrame(rows, columns=list(CASE_COLUMNS)).to_csv(cases_path, index=False)
    table = group_table(rows)
    table.to_csv(table_path)
    return cases_path, table_path, table
