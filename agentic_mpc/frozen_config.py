"""The one base of every configuration model: typed, validated, immutable."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class FrozenConfig(BaseModel):
    """A configuration: unknown keys are errors (a typo is never silently ignored), NaN and infinities are
    refused, and an instance never changes once validated (derive a new one with ``model_copy``)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)
