"""Speed arithmetic of the offline rules backend: stated, relative, clamped to the tools' limit, tidied."""

from __future__ import annotations

from agentic_mpc.agent.backends.base import ToolSpec
from agentic_mpc.agent.backends.rules_lexicon import SLOW_DOWN_FACTOR, SPEED_UP_FACTOR
from agentic_mpc.agent.backends.rules_parsing import Interpretation
from agentic_mpc.agent.backends.rules_state import DrivingState
from agentic_mpc.mcp.protocol import SPEED_ARGUMENT


def speed_limit(tools: dict[str, ToolSpec]) -> float | None:
    """The largest speed the tools accept: the upper bound of their speed argument (the road's limit)."""
    bounds = [spec.number_bounds(SPEED_ARGUMENT)[1] for spec in tools.values()]
    return next((bound for bound in bounds if bound is not None), None)


def explicit_speed(meaning: Interpretation, current: DrivingState, initial: DrivingState) -> float | None:
    """A speed the message states with a unit (or "stop"), in m/s; None when it states none."""
    v_now = current.v_ref_mps if current.v_ref_mps is not None else (initial.v_ref_mps or 0.0)
    usable = [p for p in meaning.speeds if not p.negated]
    if usable:
        phrase = usable[-1]
        if phrase.mode == "set":
            return phrase.value_mps
        if phrase.mode == "by":
            slower = phrase.sign < 0 if phrase.sign else meaning.slow_down and not meaning.speed_up
            return v_now - phrase.value_mps if slower else v_now + phrase.value_mps
        if phrase.mode == "cap":
            return min(v_now, phrase.value_mps)
        return max(v_now, phrase.value_mps)
    if meaning.stop and not meaning.speeds:
        return 0.0
    return None


def relative_speed(meaning: Interpretation, current: DrivingState, initial: DrivingState) -> float | None:
    """"Slow down" / "speed up" without a number (None if the message has a number without a unit)."""
    if meaning.speeds or meaning.bare_number:
        return None
    v_now = current.v_ref_mps if current.v_ref_mps is not None else (initial.v_ref_mps or 0.0)
    if meaning.slow_down and not meaning.speed_up:
        return v_now * SLOW_DOWN_FACTOR
    if meaning.speed_up and not meaning.slow_down:
        return v_now * SPEED_UP_FACTOR if v_now > 0 else (initial.v_ref_mps or 0.0)
    return None


def clamped(wanted: float | None, v_max: float | None) -> tuple[float | None, str | None]:
    if wanted is None:
        return None, None
    if wanted < 0:
        return 0.0, "A speed cannot be negative; stopping instead."
    if v_max is not None and wanted > v_max:
        return v_max, f"{wanted:g} m/s is above the road speed limit; using the limit, {v_max:g} m/s."
    return wanted, None


def tidy(value: float) -> float | int:
    """Whole numbers as ints (15, not 15.0) so transcripts read like the paper; others to 3 decimals."""
    rounded = round(float(value), 3)
    return int(rounded) if rounded == int(rounded) else rounded
