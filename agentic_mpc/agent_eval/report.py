"""The suite's results: a summary (accuracy by category, failed calls, latency), a printed table, and the
files ``--out`` writes: ``turns.csv`` (one row per turn: the answer, the calls, the verdict, the latency),
``cases.json`` (every case with its turns), ``summary.json`` and ``categories.csv``."""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from agentic_mpc.agent_eval.runner import CaseResult, TurnResult
from agentic_mpc.agent_eval.scoring import show_calls

TURN_COLUMNS = ("case_id", "category", "world", "turn", "turns", "message", "expected", "calls", "verdict",
                "detail", "answer", "ended", "latency_s", "repeats", "unparsed", "invalid", "v_ref_before_mps",
                "answers", "prompt_tokens", "cached_tokens", "generated_tokens", "model_s", "wall_per_model")


def percentile(values: Sequence[float], q: float) -> float:
    """The ``q``-th percentile (0-100), linear between order statistics; NaN for no values."""
    if not values:
        return float("nan")
    ordered = sorted(values)
    position = (len(ordered) - 1) * q / 100.0
    low = math.floor(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (position - low)


def summarise(results: Sequence[CaseResult], categories: dict[str, str], about: dict[str, Any]) -> dict[str, Any]:
    """The summary: ``about`` (backend, model, suite, ...) and the counts."""
    turns = [t for r in results for t in r.turns]
    latencies = [t.latency_s for t in turns]
    ratios = [t.wall_per_model for t in turns if t.wall_per_model is not None]
    first = turns[0] if turns else None
    by_category = {}
    for name in categories:
        chosen = [r for r in results if r.case.category == name]
        if chosen:
            right = sum(r.right for r in chosen)
            by_category[name] = {"cases": len(chosen), "right": right, "accuracy": round(right / len(chosen), 3)}
    dialogues = [r for r in results if len(r.case.turns) > 1]
    right_cases = sum(r.right for r in results)
    return {
        **about,
        "cases": len(results),
        "cases_right": right_cases,
        "accuracy": round(right_cases / len(results), 3) if results else float("nan"),
        "turns": len(turns),
        "turns_right": sum(t.right for t in turns),
        "dialogues": len(dialogues),
        "dialogues_right": sum(r.right for r in dialogues),
        "by_category": by_category,
        "turns_with_unparsed": sum(bool(t.unparsed) for t in turns),
        "unparsed_calls": sum(len(t.unparsed) for t in turns),
        "turns_with_invalid": sum(bool(t.invalid) for t in turns),
        "invalid_calls": sum(len(t.invalid) for t in turns),
        "backend_errors": sum(t.ended == "backend_error" for t in turns),
        "round_limit": sum(t.ended == "round_limit" for t in turns),
        "gave_up": sum(t.ended == "gave_up" for t in turns),
        "latency_p50_s": round(percentile(latencies, 50), 3),
        "latency_p95_s": round(percentile(latencies, 95), 3),
        "latency_max_s": round(max(latencies), 3) if latencies else float("nan"),
        "latency_total_s": round(sum(latencies), 3),
        "first_turn_latency_s": None if first is None else first.latency_s,
        "model": {  # what the model's server reported (llama.cpp); nothing for the rules or a silent server
            "turns_timed": len(ratios),
            "wall_per_model_p50": round(percentile(ratios, 50), 3),
            "wall_per_model_p95": round(percentile(ratios, 95), 3),
            "first_turn_wall_per_model": None if first is None or first.wall_per_model is None
            else round(first.wall_per_model, 3),
            "model_s_p50": round(percentile([t.model_s for t in turns if t.model_s is not None], 50), 3),
            "prompt_tokens_p50": percentile([t.prompt_tokens for t in turns], 50),
            "generated_tokens_p50": percentile([t.generated_tokens for t in turns], 50),
            "answers_p50": percentile([t.answers for t in turns], 50),
            "prompt_tokens_total": sum(t.prompt_tokens for t in turns),
            "cached_tokens_total": sum(t.cached_tokens for t in turns),
            "generated_tokens_total": sum(t.generated_tokens for t in turns),
        },
        "ended_on_budget": sum(t.ended == "budget" for t in turns),
        "ended_undone": sum(t.ended == "undone" for t in turns),
    }


def table(summary: dict[str, Any]) -> str:
    """The summary as a text table."""
    lines = [f"{'category':<14} {'cases':>5} {'right':>5} {'accuracy':>8}"]
    for name, row in summary["by_category"].items():
        lines.append(f"{name:<14} {row['cases']:>5} {row['right']:>5} {row['accuracy']:>8.0%}")
    lines.append(f"{'all':<14} {summary['cases']:>5} {summary['cases_right']:>5} {summary['accuracy']:>8.0%}")
    lines.append(
        f"turns right {summary['turns_right']}/{summary['turns']}; dialogues right {summary['dialogues_right']}/"
        f"{summary['dialogues']}; unparsed calls {summary['unparsed_calls']} (in {summary['turns_with_unparsed']} "
        f"turns); invalid calls {summary['invalid_calls']} (in {summary['turns_with_invalid']} turns); backend "
        f"errors {summary['backend_errors']}; round limit {summary['round_limit']}; gave up {summary['gave_up']}"
    )
    lines.append(f"latency per turn: p50 {summary['latency_p50_s']:.2f} s, p95 {summary['latency_p95_s']:.2f} s, "
                 f"max {summary['latency_max_s']:.2f} s, total {summary['latency_total_s']:.0f} s")
    model = summary["model"]
    if model["turns_timed"]:
        lines.append(f"the model's own time: p50 {model['model_s_p50']:.2f} s a turn ({model['prompt_tokens_p50']:.0f} "
                     f"prompt tokens processed, {model['generated_tokens_p50']:.0f} generated, "
                     f"{model['answers_p50']:.0f} answer(s)); wall / model p50 {model['wall_per_model_p50']:.2f}, "
                     f"p95 {model['wall_per_model_p95']:.2f}; steps ended on the budget {summary['ended_on_budget']}, "
                     f"on an undone call {summary['ended_undone']}")
    return "\n".join(lines)


def turn_row(turn: TurnResult) -> dict[str, Any]:
    return {
        "case_id": turn.case_id, "category": turn.category, "world": turn.world, "turn": turn.turn,
        "turns": turn.turns, "message": turn.message, "expected": turn.expected, "calls": show_calls(turn.calls),
        "verdict": "right" if turn.right else "wrong", "detail": turn.detail, "answer": turn.answer,
        "ended": turn.ended, "latency_s": turn.latency_s, "repeats": turn.repeats,
        "unparsed": " | ".join(turn.unparsed), "invalid": " | ".join(turn.invalid),
        "v_ref_before_mps": turn.v_ref_before_mps, "answers": turn.answers, "prompt_tokens": turn.prompt_tokens,
        "cached_tokens": turn.cached_tokens, "generated_tokens": turn.generated_tokens, "model_s": turn.model_s,
        "wall_per_model": None if turn.wall_per_model is None else round(turn.wall_per_model, 3),
    }


def write(out_dir: Path, results: Sequence[CaseResult], summary: dict[str, Any]) -> list[Path]:
    """Write the result files into ``out_dir``; returns their paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    turns_csv = out_dir / "turns.csv"
    with turns_csv.open("w", newline="", encoding="utf-8") as file:
        writer = csv.DictWriter(file, fieldnames=TURN_COLUMNS)
        writer.writeheader()
        for result in results:
            for turn in result.turns:
                writer.writerow(turn_row(turn))
    cases_json = out_dir / "cases.json"
    cases = [{"id": r.case.id, "category": r.case.category, "world": r.case.world, "right": r.right,
              "turns": [{**turn_row(t), "calls": t.calls, "errors": t.errors, "unparsed": t.unparsed,
                         "invalid": t.invalid} for t in r.turns]} for r in results]
    cases_json.write_text(json.dumps(cases, indent=1, ensure_ascii=False), encoding="utf-8")
    summary_json = out_dir / "summary.json"
    summary_json.write_text(json.dumps(summary, indent=1, ensure_ascii=False), encoding="utf-8")
    categories_csv = out_dir / "categories.csv"
    with categories_csv.open("w", newline="", encoding="utf-8") as file:
        writer = csv.writer(file)
        writer.writerow(("category", "cases", "right", "accuracy"))
        for name, row in summary["by_category"].items():
            writer.writerow((name, row["cases"], row["right"], row["accuracy"]))
        writer.writerow(("all", summary["cases"], summary["cases_right"], summary["accuracy"]))
    return [turns_csv, cases_json, summary_json, categories_csv]


def write_rows(path: Path, rows: Sequence[dict[str, Any]], columns: Sequence[str]) -> Path:
    """``rows`` as a CSV file with ``columns``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="", encoding="utf-8") as file:
        writer = csv.DictWriter(file, fieldnames=list(columns), extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    return path
