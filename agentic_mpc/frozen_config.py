"""The one base of every configuration model: typed, validated, immutable."""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict, model_validator


class FrozenConfig(BaseModel):
    """A configuration: unknown keys are errors (a typo is never silently ignored), NaN and infinities are
    refused, and an instance never changes once validated (derive a new one with ``model_copy``).

    A model lists the keys it no longer takes in ``removed_fields`` (key: what became of it; the messages are
    ``agentic_mpc/removed_options.py``), so that a file that still names one is told so, not only that it is
    unknown."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)
    removed_fields: ClassVar[dict[str, str]] = {}

    @model_validator(mode="before")
    @classmethod
    def _refuse_removed_fields(cls, data: Any) -> Any:
        if cls.removed_fields and isinstance(data, dict):
            named = [key for key in data if key in cls.removed_fields]
            if named:
                raise ValueError("; ".join(f"{key!r} was removed: {cls.removed_fields[key]}" for key in named))
        return data
