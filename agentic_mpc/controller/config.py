"""Fourier MPPI settings: the paper's where it gives them, measured choices where it does not."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator


class MPPIConfig(BaseModel):
    """Settings of :class:`~agentic_mpc.controller.mppi.FourierMPPI`.

    The paper fixes L = 4, S = 256 and the standard deviations; it gives neither the horizon nor the
    temperature. The defaults here were chosen by the closed-loop measurements in docs/cost-design.md.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    horizon: int = Field(50, ge=2, le=1000, description="prediction horizon H in steps (50 = 2 s)")
    samples: int = Field(256, ge=2, le=1_000_000, description="sampled coefficient vectors S")
    order: int = Field(4, ge=0, le=20, description="Fourier truncation order L")
    temperature: float = Field(1.0, gt=0, description="MPPI temperature T: weights exp(-(J - J_min) / T)")
    steer_std: float = Field(0.8, gt=0, description="std of beta_delta,0; harmonic l gets steer_std * decay**l")
    throttle_brake_std: float = Field(0.3, gt=0, description="std of beta_ab,0; harmonic l gets ... * decay**l")
    std_decay: float = Field(0.8, gt=0, le=1.0, description="per-order decay of the standard deviations")
    warm_start: Literal["previous", "shifted"] = Field(
        "shifted",
        description="mean of the next step: the previous optimum as the paper says, or it shifted by one step",
    )
    antithetic: bool = Field(True, description="sample noise in +/- pairs (halves random draws, same marginals)")
    include_mean: bool = Field(True, description="replace the first sample by the unperturbed mean")
    backend: Literal["fast", "reference"] = Field("fast", description="fused Numba kernel or the NumPy reference")

    @model_validator(mode="after")
    def _even_samples_for_antithetic(self) -> MPPIConfig:
        if self.antithetic and self.samples % 2:
            raise ValueError(f"samples must be even with antithetic sampling, got {self.samples}")
        return self

    @property
    def coefficients(self) -> int:
        return 2 * self.order + 1
