"""What a turn expects: the calls (:class:`CallSpec`), each argument's tolerance (:class:`Constraint`), the
alternatives (:class:`Turn`). The file format is described in :mod:`agentic_mpc.agent_eval.suite`."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

NUMBER_TOLERANCE = 0.01
"""A plain number in ``args`` matches within this (a model writes 15.0 for 15)."""


@dataclass(frozen=True, slots=True)
class Constraint:
    """What one argument must be (see the module docstring)."""

    kind: str  # exact | approx | range | relative | one_of | any
    value: Any = None
    low: float = -math.inf
    high: float = math.inf

    def matches(self, value: Any, current_v_ref_mps: float | None) -> bool:
        if self.kind == "any":
            return True
        if self.kind in ("exact", "one_of"):
            options = self.value if self.kind == "one_of" else (self.value,)
            return any(_same(value, option) for option in options)
        if not is_number(value):
            return False
        low, high = self.low, self.high
        if self.kind == "relative":
            if current_v_ref_mps is None:
                return False
            low, high = low * current_v_ref_mps, high * current_v_ref_mps
        return low - 1e-9 <= float(value) <= high + 1e-9

    def describe(self, current_v_ref_mps: float | None = None) -> str:
        if self.kind == "exact":
            return repr(self.value)
        if self.kind == "one_of":
            return " | ".join(map(repr, self.value))
        if self.kind == "any":
            return "any"
        if self.kind == "approx":
            return f"{(self.low + self.high) / 2:g}±{(self.high - self.low) / 2:g}"
        if self.kind == "relative" and current_v_ref_mps is not None:
            return f"[{self.low * current_v_ref_mps:.3g}, {self.high * current_v_ref_mps:.3g}]"
        return f"[{self.low:g}, {self.high:g}]" + ("×current" if self.kind == "relative" else "")


def is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _same(value: Any, expected: Any) -> bool:
    if is_number(expected):
        return is_number(value) and abs(float(value) - float(expected)) <= NUMBER_TOLERANCE
    return value == expected


@dataclass(frozen=True, slots=True)
class CallSpec:
    """One expected call: any of ``tools``, with every named argument within its constraint."""

    tools: tuple[str, ...]
    args: tuple[tuple[str, Constraint], ...] = ()

    def matches(self, tool: str, arguments: dict[str, Any] | None, current_v_ref_mps: float | None) -> bool:
        if tool not in self.tools or arguments is None:
            return False
        return all(name in arguments and c.matches(arguments[name], current_v_ref_mps) for name, c in self.args)

    def describe(self, current_v_ref_mps: float | None = None) -> str:
        args = ", ".join(f"{name}={c.describe(current_v_ref_mps)}" for name, c in self.args)
        return f"{'|'.join(self.tools)}({args})"


@dataclass(frozen=True, slots=True)
class Turn:
    message: str
    expect: tuple[CallSpec, ...]
    alternatives: tuple[tuple[CallSpec, ...], ...] = ()
    cites: tuple[str, ...] = ()
    """Documents (knowledge ids) one of which the answer must name: a turn that needs a document."""

    @property
    def options(self) -> tuple[tuple[CallSpec, ...], ...]:
        """Every right set of calls: ``expect`` first."""
        return (self.expect, *self.alternatives)

    def describe(self, current_v_ref_mps: float | None = None) -> str:
        def one(calls: tuple[CallSpec, ...]) -> str:
            return " + ".join(c.describe(current_v_ref_mps) for c in calls) or "(no call)"

        return " OR ".join(one(calls) for calls in self.options)
