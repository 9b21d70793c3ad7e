"""Scoring one turn: what the agent's step did (a :class:`~agentic_mpc.agent.report.StepReport`'s tool calls)
against what the turn expects.

- The calls that count are the ones the MCP server **accepted** (they changed the specification). Exact
  repeats of an accepted call (same tool, same arguments) count once: every tool sets absolute values, so a
  repeat changes nothing (small models tend to repeat a call after its result).
- Right: the accepted calls match one of the turn's expected call lists one to one, in any order; a missing
  call or an extra one is wrong. A turn that expects no call is wrong if the agent *tried* any call, even
  one that was refused.
- Failed attempts are counted apart: **unparsed** (text that looked like a call but could not be read, or
  named no listed tool) and **invalid** (a listed tool with arguments outside its schema, or refused by the
  controller).
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from agentic_mpc.agent_eval.expectations import CallSpec, Turn


@dataclass(frozen=True, slots=True)
class Attempts:
    """The tool calls of one agent step, sorted by outcome."""

    accepted: tuple[dict[str, Any], ...]
    """{"tool", "arguments"} of each accepted call, exact repeats removed."""
    repeats: int
    unparsed: tuple[str, ...]
    invalid: tuple[str, ...]

    @property
    def tried(self) -> int:
        return len(self.accepted) + self.repeats + len(self.unparsed) + len(self.invalid)


def sort_attempts(tool_calls: Iterable[dict[str, Any]], listed_tools: Iterable[str]) -> Attempts:
    """Sort a StepReport's ``tool_calls`` (each: tool, arguments, ok, result or error)."""
    listed = set(listed_tools)
    accepted: list[dict[str, Any]] = []
    seen: set[str] = set()
    repeats = 0
    unparsed: list[str] = []
    invalid: list[str] = []
    for call in tool_calls:
        tool, arguments = call.get("tool"), call.get("arguments")
        if call.get("ok"):
            key = json.dumps([tool, arguments], sort_keys=True, default=str)
            if key in seen:
                repeats += 1
            else:
                seen.add(key)
                accepted.append({"tool": tool, "arguments": arguments})
            continue
        why = f"{tool}: {str(call.get('error', ''))[:200]}"
        (invalid if tool in listed and arguments is not None else unparsed).append(why)
    return Attempts(tuple(accepted), repeats, tuple(unparsed), tuple(invalid))


def matches_exactly(calls: Sequence[dict[str, Any]], expected: Sequence[CallSpec],
                    current_v_ref_mps: float | None) -> bool:
    """Whether ``calls`` and ``expected`` pair up one to one (any order), each call within its spec."""
    if len(calls) != len(expected):
        return False

    def assign(index: int, free: list[int]) -> bool:  # backtracking: a turn has a handful of calls at most
        if index == len(calls):
            return True
        call = calls[index]
        for position, spec_index in enumerate(free):
            if expected[spec_index].matches(call["tool"], call["arguments"], current_v_ref_mps) and assign(
                index + 1, free[:position] + free[position + 1:]
            ):
                return True
        return False

    return assign(0, list(range(len(expected))))


@dataclass(frozen=True, slots=True)
class Verdict:
    right: bool
    detail: str = ""


def judge(turn: Turn, attempts: Attempts, current_v_ref_mps: float | None,
          backend_failed: bool = False, answer: str = "") -> Verdict:
    """The verdict on one turn (see the module docstring); a turn with ``cites`` is right only if the answer
    also names one of those documents."""
    verdict = _judge_calls(turn, attempts, current_v_ref_mps, backend_failed)
    if verdict.right and turn.cites and not any(doc in answer for doc in turn.cites):
        return Verdict(False, f"the answer cites none of {', '.join(turn.cites)}")
    return verdict


def _judge_calls(turn: Turn, attempts: Attempts, current_v_ref_mps: float | None, backend_failed: bool) -> Verdict:
    calls = list(attempts.accepted)
    if backend_failed and not calls:
        return Verdict(False, "no answer from the backend")
    for option in turn.options:
        if not option:
            if attempts.tried == 0:
                return Verdict(True)
            continue
        if matches_exactly(calls, option, current_v_ref_mps):
            return Verdict(True)
    made = ", ".join(_show(c) for c in calls) or "no accepted call"
    if not turn.expect and not turn.alternatives:
        return Verdict(False, f"expected no call, tried {attempts.tried}: {made}")
    return Verdict(False, f"made {made}; expected {turn.describe(current_v_ref_mps)}")


def _show(call: dict[str, Any]) -> str:
    arguments = call.get("arguments") or {}
    return f"{call['tool']}({', '.join(f'{k}={v!r}' for k, v in arguments.items())})"


def show_calls(calls: Iterable[dict[str, Any]]) -> str:
    """``tool(arg=value, ...)`` of each call, joined by "; "."""
    return "; ".join(_show(c) for c in calls)
