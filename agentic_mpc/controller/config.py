"""Fourier MPPI settings: the paper's where it gives them, measured choices where it does not."""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import Field, model_validator

from agentic_mpc import removed_options
from agentic_mpc.frozen_config import FrozenConfig


class MPPIConfig(FrozenConfig):
    """Settings of :class:`~agentic_mpc.controller.mppi.FourierMPPI`.

    The paper fixes L = 4, S = 256 and the standard deviations; it gives neither the horizon nor the
    temperature. The defaults here were chosen by the closed-loop measurements in docs/cost-design.md.
    """

    removed_fields: ClassVar[dict[str, str]] = removed_options.CONTROLLER


    horizon: int = Field(50, ge=2, le=1000, description="prediction horizon H in steps (50 = 2 s)")
    samples: int = Field(256, ge=2, le=1_000_000, description="sampled coefficient vectors S")
    order: int = Field(4, ge=0, le=20, description="Fourier truncation order L")
    temperature: float = Field(
        1.0, gt=0, description="MPPI temperature T: weights exp(-(J - J_min) / T); with ess_band, where T starts"
    )
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
    # The levers that make the weighted average meaningful (docs/cost-design.md, "A meaningful average").
    # Each has a value that gives back the paper's plain algorithm: harmonic_std_scale 1, first_input_noise
    # "paper", ess_band None, elite_samples None, input_smoothing 0.
    harmonic_std_scale: float = Field(
        0.2, gt=0, le=1.0, description="factor on the harmonics' std (l >= 1); 1 = the paper's per-order stds"
    )
    first_input_noise: Literal["pinned", "paper"] = Field(
        "pinned",
        description="'pinned': the coefficient noise is conditioned so that u(0) has none (the applied input "
        "continues the previous plan); 'paper': u(0) gets the noise of beta_0 + sum beta_l",
    )
    free_start_below_mps: float | None = Field(
        0.1,
        ge=0,
        description="with pinned noise: below this speed, when the specification asks for motion, u(0) gets the "
        "paper's noise after all (a standing car's warm-started brake would otherwise hold every sample still: "
        "braking does nothing at 0 m/s, so no cost ever moves it; docs/traffic.md); None: always pinned",
    )
    pinned_level_share: float = Field(
        1.0,
        ge=0,
        le=1.0,
        description="with pinned noise: 1 = the Gaussian conditioned on u(0) (beta_0 varies little), 0 = beta_0 "
        "keeps the paper's spread and the cosines absorb the correction (fourier.noise_with_fixed_start)",
    )
    ess_band: tuple[float, float] | None = Field(
        (0.05, 0.2),
        description="effective sample size held in [low, high] x S by adapting the temperature each step "
        "(None: the temperature stays fixed)",
    )
    elite_samples: int | None = Field(
        None, ge=1, description="average only the this many lowest-cost samples (None: all samples)"
    )
    input_smoothing: float = Field(
        0.0, ge=0, lt=1.0, description="exponential low-pass on the applied input: u = s u_prev + (1 - s) u*(0)"
    )

    @model_validator(mode="after")
    def _consistent(self) -> MPPIConfig:
        if self.antithetic and self.samples % 2:
            raise ValueError(f"samples must be even with antithetic sampling, got {self.samples}")
        if self.ess_band is not None:
            low, high = self.ess_band
            if not 0 < low <= high <= 1:
                raise ValueError(f"ess_band must satisfy 0 < low <= high <= 1 (fractions of S), got {self.ess_band}")
        if self.first_input_noise == "pinned" and self.order < 1:
            raise ValueError("first_input_noise 'pinned' needs order >= 1 (the harmonics carry the correction)")
        if self.elite_samples is not None and self.elite_samples > self.samples:
            raise ValueError(f"elite_samples ({self.elite_samples}) must not exceed samples ({self.samples})")
        return self

    @property
    def coefficients(self) -> int:
        return 2 * self.order + 1
