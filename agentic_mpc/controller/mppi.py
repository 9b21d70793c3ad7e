"""Fourier MPPI: sample Fourier coefficients of the input sequences, roll out, weight, average.

One control step (``FourierMPPI.step``):

1. bind the specification to the current state (reference points etc.);
2. sample S coefficient vectors around the mean, z_s = z_bar + M eps_s, for steering and for
   throttle/brake: the paper's per-order standard deviations (harmonics scaled by ``harmonic_std_scale``),
   by default conditioned so that no sample moves the first input (``first_input_noise="pinned"``);
3. synthesise the input sequences, roll out the vehicle model, add up the attached primitives' costs;
4. w_s = exp(-(J_s - min J) / T), z* = sum w_s z_s / sum w_s, with T adapted each step so that the
   effective sample size stays in ``ess_band`` (optionally over the ``elite_samples`` best only);
5. apply u*(0), the first input of z*, and keep z* as the next step's mean (warm start).

Why the levers of steps 2 and 4 exist, and what each measured: docs/cost-design.md.

Step 3 runs in the fused Numba kernel when every attached primitive has a fused form, and in plain NumPy
otherwise (or with ``backend="reference"``). On the fast backend steps 2, 4 and 5 are compiled too
(``coefficient_kernels.assemble_samples``, ``weighting.weigh_and_average``, ``coefficient_kernels.start_and_shift``):
around a 0.3 ms kernel, their NumPy forms cost another 0.3 ms per step on the project machine. The reference
backend keeps all of it in NumPy; the two agree to float tolerance (tests/controller).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from agentic_mpc.controller import coefficient_kernels, fourier, kernels, weighting
from agentic_mpc.controller.config import MPPIConfig
from agentic_mpc.controller.rollout import rollout
from agentic_mpc.primitives.base import Rollouts, StepContext, Surroundings
from agentic_mpc.primitives.specification import PreparedSpecification, Specification
from agentic_mpc.vehicle import PAPER_PARAMS, STEER_LIMIT, VehicleParams


@dataclass(frozen=True, slots=True)
class ControlOutput:
    """The input to apply now and what the optimisation looked like."""

    delta: float
    throttle: float
    brake: float
    cost_min: float
    """Lowest sampled cost."""
    effective_samples: float
    """(sum w)^2 / sum w^2: how many samples really carry the average (1 = one sample dominates)."""
    effective_fraction: float
    """``effective_samples`` / S."""
    temperature: float
    """The temperature the weights used (adapted when ``ess_band`` is set)."""
    solve_ms: float
    used_fast_path: bool

    @property
    def inputs(self) -> np.ndarray:
        return np.array([self.delta, self.throttle, self.brake])


class FourierMPPI:
    """The controller. It knows the vehicle model and the primitives, nothing of SUMO, MCP or the agent."""

    def __init__(
        self, config: MPPIConfig | None = None, params: VehicleParams = PAPER_PARAMS, seed: int | None = 0
    ) -> None:
        self.config = config or MPPIConfig()
        self.params = params
        c = self.config
        self.basis = np.ascontiguousarray(fourier.basis(c.order, c.horizon))
        self._shift = fourier.OneStepShift(c.order, c.horizon)
        harmonic_scale = np.r_[1.0, np.full(2 * c.order, c.harmonic_std_scale)]
        self.std = np.stack(
            [
                fourier.coefficient_std(c.steer_std, c.std_decay, c.order) * harmonic_scale,
                fourier.coefficient_std(c.throttle_brake_std, c.std_decay, c.order) * harmonic_scale,
            ]
        )  # (2, 2L+1): steering, throttle/brake
        # eps -> coefficient noise: diag(std) as the paper samples, or its projection that leaves u(0) alone.
        self._noise_map = (
            np.stack([fourier.noise_with_fixed_start(std, c.pinned_level_share) for std in self.std])
            if c.first_input_noise == "pinned"
            else None
        )
        self._fast = c.backend == "fast"
        self._free_map = np.ascontiguousarray(np.stack([np.diag(std) for std in self.std]))
        self._compiled_noise_map = np.ascontiguousarray(self._noise_map if self._noise_map is not None else self._free_map)
        self.rng = np.random.default_rng(seed)
        self._params_packed = kernels.pack_params(params)
        # Buffers allocated once: re-allocating (2L+1, S) and (10, S) arrays every step costs measurably.
        self._z = np.empty((2, c.coefficients, c.samples))
        self._noise = np.empty((2, c.coefficients, c.samples // 2 if c.antithetic else c.samples))
        self._scaled = np.empty_like(self._noise)
        self._work = np.empty((10, c.samples))
        self._costs = np.empty(c.samples)
        self._weights = np.empty(c.samples)
        self.mean = np.zeros((2, c.coefficients))
        self.optimum = self.mean
        self.previous_input = (0.0, 0.0)  # (delta, throttle/brake) applied last step, for J0's rate term
        self.temperature = c.temperature

    def reset(self, mean: np.ndarray | None = None) -> None:
        """Forget the warm start (or set it: shape (2, 2L+1), steering then throttle/brake)."""
        self.mean = np.zeros((2, self.config.coefficients)) if mean is None else np.array(mean, dtype=np.float64)
        self.optimum = self.mean
        """The weighted-mean coefficients of the last step (before the warm-start shift)."""
        self.previous_input = (0.0, 0.0)
        self.temperature = self.config.temperature

    def sample(self, free_start: bool = False) -> np.ndarray:
        """Draw coefficient samples around the mean into the buffer, shape (2, 2L+1, S); ``free_start``: u(0)
        gets noise even when the configuration pins it."""
        c = self.config
        z = self._z
        self.rng.standard_normal(out=self._noise)
        if self._fast:  # the same arithmetic, compiled (tests/controller/test_mppi.py compares the two)
            noise_map = self._free_map if free_start else self._compiled_noise_map
            coefficient_kernels.assemble_samples(noise_map, self._noise, self.mean, c.antithetic, c.include_mean, z)
            return z
        if self._noise_map is not None and not free_start:  # a fixed-order product: no BLAS (docs/reproducibility.md)
            self._scaled[...] = 0.0
            for j in range(c.coefficients):
                self._scaled += self._noise_map[:, :, j, None] * self._noise[:, None, j, :]
        else:
            np.multiply(self._noise, self.std[:, :, None], out=self._scaled)
        if c.antithetic:
            half = c.samples // 2
            z[:, :, :half] = self._scaled
            np.negative(self._scaled, out=z[:, :, half:])
        else:
            z[...] = self._scaled
        if c.include_mean:
            z[:, :, 0] = 0.0
        z += self.mean[:, :, None]
        return z

    def context(self, state: np.ndarray, surroundings: Surroundings = Surroundings()) -> StepContext:
        return StepContext(
            state=state,
            horizon=self.config.horizon,
            params=self.params,
            surroundings=surroundings,
            previous_input=self.previous_input,
        )

    def costs(self, prepared: PreparedSpecification, state: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, bool]:
        """Cost of every sample; ``z`` is (2, 2L+1, S). Returns (costs, whether the fused kernel ran)."""
        fused = prepared.fused_arrays() if self.config.backend == "fast" else None
        if fused is not None:
            kernels.fused_costs(state, self._params_packed, self.basis, z[0], z[1], fused, self._work, self._costs)
            return self._costs, True
        return prepared.cost(self.rollouts(state, z)), False

    def rollouts(self, state: np.ndarray, z: np.ndarray) -> Rollouts:
        """Materialised rollouts of coefficient samples (2, 2L+1, S), the NumPy reference."""
        return rollout(state, z[0], z[1], self.basis, self.params)

    def step(
        self, state: np.ndarray, specification: Specification, surroundings: Surroundings = Surroundings()
    ) -> ControlOutput:
        """One MPPI iteration from ``state`` = [x_m, y_m, phi_rad, v_mps] under ``specification``."""
        started = time.perf_counter()
        state = np.asarray(state, dtype=np.float64)
        if state.shape != (4,) or not all(map(math.isfinite, state.tolist())):  # np.all costs ~10 us here
            raise ValueError(f"state must be 4 finite numbers [x_m, y_m, phi_rad, v_mps], got {state!r}")
        prepared = specification.prepare(self.context(state, surroundings))
        free_start = self._free_start(state, specification)
        z = self.sample(free_start)
        costs, fast = self.costs(prepared, state, z)
        weights, optimum = self.average(costs, z)
        if weights.found:
            self.temperature = weights.temperature
        else:  # every sample's cost was NaN or infinite: keep the previous plan rather than average garbage
            optimum = self.mean
        self.optimum = optimum
        if self._fast:
            shifted = np.empty_like(optimum)
            delta_now, ab_now = coefficient_kernels.start_and_shift(optimum, self._shift.cos, self._shift.sin, shifted)
        else:
            delta_now, ab_now = (float(v) for v in fourier.value_at_start(optimum))
            shifted = self._shift(optimum)
        self.mean = shifted if self.config.warm_start == "shifted" else optimum
        smoothing = self.config.input_smoothing
        if smoothing:
            delta_now = smoothing * self.previous_input[0] + (1.0 - smoothing) * delta_now
            ab_now = smoothing * self.previous_input[1] + (1.0 - smoothing) * ab_now
        # Scalar saturations in plain Python: np.clip on scalars costs microseconds each.
        delta_now = min(max(delta_now, -STEER_LIMIT), STEER_LIMIT)
        ab_now = min(max(ab_now, -1.0), 1.0)
        self.previous_input = (delta_now, ab_now)
        return ControlOutput(
            delta=delta_now,
            throttle=max(ab_now, 0.0),
            brake=-min(ab_now, 0.0),
            cost_min=weights.cost_min,
            effective_samples=weights.effective_samples,
            effective_fraction=weights.effective_samples / self.config.samples,
            temperature=weights.temperature,
            solve_ms=(time.perf_counter() - started) * 1e3,
            used_fast_path=fast,
        )

    def _free_start(self, state: np.ndarray, specification: Specification) -> bool:
        """Whether this step samples u(0) too: standing, pinned, and asked to move. Pinning keeps the applied
        input continuous while driving; at 0 m/s it would keep the warm-started brake for ever, since braking
        a standing car changes no rollout and so no cost (docs/traffic.md, "An incident in traffic")."""
        below = self.config.free_start_below_mps
        return (self._noise_map is not None and below is not None and float(state[3]) < below
                and specification.asks_for_motion)

    def average(self, costs: np.ndarray, z: np.ndarray) -> tuple[Weighting, np.ndarray]:
        """This step's weights and the weighted mean of the samples ``z`` (2, 2L+1, S); the mean is
        meaningless when ``Weighting.found`` is False (no finite cost)."""
        c = self.config
        if not self._fast or c.elite_samples is not None:
            weighting_ = self.weights(costs, self.temperature)
            if weighting_.weights is None:
                return weighting_, self.mean
            return weighting_, (z * weighting_.weights).sum(axis=-1)  # not einsum: its SIMD order is the CPU's
        optimum = np.empty((2, c.coefficients))
        low, high = c.ess_band if c.ess_band is not None else (0.0, 0.0)
        found, cost_min, temperature, ess = weighting.weigh_and_average(
            costs, z, self.temperature, low * c.samples, high * c.samples, c.ess_band is not None, self._weights, optimum
        )
        return Weighting(self._weights if found else None, cost_min, temperature, ess), optimum

    def planned_states(self, state: np.ndarray) -> np.ndarray:
        """The optimal predicted trajectory of the last step: its weighted-mean coefficients rolled out from
        ``state`` (the state that step started from), shape (H, 4). For recording and replays; not on the
        hot path."""
        z = self.optimum[:, :, None]
        rolled = self.rollouts(np.asarray(state, dtype=np.float64), z)
        return np.stack([rolled.x_m[:, 0], rolled.y_m[:, 0], rolled.phi_rad[:, 0], rolled.v_mps[:, 0]], axis=1)

    def weights(self, costs: np.ndarray, temperature: float | None = None) -> Weighting:
        """Normalised MPPI weights exp(-(J - min J) / T) (sum 1); ``weights`` is None if no sample has a
        finite cost. ``temperature`` is where the ESS band's search starts (or the fixed T without a band)."""
        c = self.config
        temperature = c.temperature if temperature is None else temperature
        finite = np.isfinite(costs)
        if not finite.any():
            return Weighting(None, float("inf"), temperature, 0.0)
        cost_min = float(costs[finite].min())
        shifted = np.where(finite, costs - cost_min, np.inf) if not finite.all() else costs - cost_min
        if c.elite_samples is not None and c.elite_samples < len(shifted):
            shifted[np.argpartition(shifted, c.elite_samples)[c.elite_samples:]] = np.inf
        if c.ess_band is not None:
            low, high = c.ess_band
            temperature, _ = weighting.temperature_for_band(shifted, temperature, low * len(costs), high * len(costs))
        weights = np.exp(-shifted / temperature)
        weights /= weights.sum()
        return Weighting(weights, cost_min, float(temperature), float(1.0 / np.sum(weights * weights)))


@dataclass(frozen=True, slots=True)
class Weighting:
    """One step's sample weights and how they came about."""

    weights: np.ndarray | None
    cost_min: float
    temperature: float
    effective_samples: float

    @property
    def found(self) -> bool:
        """Whether some sample had a finite cost (else there are no weights)."""
        return self.weights is not None
