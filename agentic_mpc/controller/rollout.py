"""The reference path: roll out every sample with the model exactly as printed, in plain NumPy."""

from __future__ import annotations

import numpy as np

from agentic_mpc.primitives.base import Rollouts
from agentic_mpc.vehicle import STEER_LIMIT, VehicleParams, split_throttle_brake, step


def synthesise(z: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Input sequences of all samples, (H, S), from coefficients (2L+1, S) and the basis (2L+1, H).

    Row by row rather than ``basis.T @ z``: a BLAS product's summation order, and so its last bit, depends on
    the CPU's kernel; elementwise products summed in a fixed order do not (docs/reproducibility.md)."""
    sequences = basis[0][:, None] * z[0][None, :]
    for row in range(1, basis.shape[0]):
        sequences += basis[row][:, None] * z[row][None, :]
    return sequences


def rollout(
    state: np.ndarray, z_delta: np.ndarray, z_ab: np.ndarray, basis: np.ndarray, params: VehicleParams
) -> Rollouts:
    """Predicted states k = 1..H and inputs k = 0..H-1 of every sample (coefficients as (2L+1, S))."""
    delta_command = synthesise(z_delta, basis)
    ab_command = synthesise(z_ab, basis)
    delta = np.clip(delta_command, -STEER_LIMIT, STEER_LIMIT)
    throttle, brake = split_throttle_brake(ab_command)
    horizon, samples = delta.shape
    states = np.empty((horizon, 4, samples))
    current = np.repeat(np.asarray(state, dtype=np.float64)[:, None], samples, axis=1)
    for k in range(horizon):
        current = step(current, delta[k], throttle[k], brake[k], params)
        states[k] = current
    return Rollouts(
        x_m=states[:, 0],
        y_m=states[:, 1],
        phi_rad=states[:, 2],
        v_mps=states[:, 3],
        delta=delta,
        throttle=throttle,
        brake=brake,
        delta_command=delta_command,
        ab_command=ab_command,
    )
