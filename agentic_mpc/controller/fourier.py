"""The truncated Fourier series that Fourier MPPI samples instead of raw input sequences.

u(k) = beta_0 + sum_{l=1..L} alpha_l sin(2 pi l k / H) + beta_l cos(2 pi l k / H),  k = 0..H-1,
with the coefficient vector z = [beta_0, alpha_1, beta_1, ..., alpha_L, beta_L] (length 2L + 1).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def basis(order: int, horizon: int) -> NDArray[np.float64]:
    """The synthesis matrix B of shape (2L + 1, H): u = z @ B."""
    if order < 0 or horizon < 1:
        raise ValueError(f"need order >= 0 and horizon >= 1, got order={order}, horizon={horizon}")
    k = np.arange(horizon)
    rows = [np.ones(horizon)]
    for harmonic in range(1, order + 1):
        angle = 2.0 * np.pi * harmonic * k / horizon
        rows += [np.sin(angle), np.cos(angle)]
    return np.array(rows)


def coefficient_std(first: float, decay: float, order: int) -> NDArray[np.float64]:
    """The paper's per-order standard deviations: ``first`` for beta_0, ``first * decay**l`` for alpha_l, beta_l."""
    return np.array([first] + [first * decay**harmonic for harmonic in range(1, order + 1) for _ in (0, 1)])


def start_row(order: int) -> NDArray[np.float64]:
    """The row a with u(0) = a . z: ones at beta_0 and every beta_l, zeros at the alpha_l."""
    row = np.zeros(2 * order + 1)
    row[0] = 1.0
    row[2::2] = 1.0
    return row


def noise_with_fixed_start(std: NDArray[np.float64], level_share: float = 1.0) -> NDArray[np.float64]:
    """The matrix M such that n = M @ eps (eps standard normal) has a . n = 0: no noise on u(0).

    n = (I - c a^T) diag(std) eps, where c (with a . c = 1) says which coefficients take back what would
    move u(0): c proportional to diag(std^2) a, with beta_0's variance weighted by ``level_share``.
    ``level_share = 1`` is the Gaussian conditioned on u(0) = 0 (every coefficient keeps its spread apart
    from the one direction that moves u(0); beta_0 then varies about as little as the harmonics);
    ``level_share = 0`` leaves beta_0 the paper's spread and lets the cosines carry the correction.
    """
    order = (len(std) - 1) // 2
    if order < 1:
        raise ValueError("pinning the first input needs at least one harmonic (order >= 1)")
    a = start_row(order)
    weights = std**2 * a
    weights[0] *= level_share
    c = weights / float(a @ weights)
    return (np.eye(len(std)) - np.outer(c, a)) * std[None, :]


def value_at_start(z: NDArray[np.float64]) -> NDArray[np.float64]:
    """u(0) = beta_0 + sum beta_l (sin 0 = 0, cos 0 = 1). Works on the last axis."""
    return z[..., 0] + z[..., 2::2].sum(axis=-1)


def shift_one_step(z: NDArray[np.float64], horizon: int) -> NDArray[np.float64]:
    """Coefficients of the same series advanced by one step: u'(k) = u(k + 1).

    Each harmonic's (alpha_l, beta_l) rotates by 2 pi l / H. The series is periodic, so the step that
    falls off the front wraps to the end; the tail is a guess either way.
    """
    return OneStepShift((np.shape(z)[-1] - 1) // 2, horizon)(z)


class OneStepShift:
    """:func:`shift_one_step` with the rotations computed once (the controller applies it every step)."""

    def __init__(self, order: int, horizon: int) -> None:
        theta = 2.0 * np.pi * np.arange(1, order + 1) / horizon
        self.cos, self.sin = np.cos(theta), np.sin(theta)  # of each harmonic's rotation

    def __call__(self, z: NDArray[np.float64]) -> NDArray[np.float64]:
        z = np.asarray(z, dtype=np.float64)
        shifted = z.copy()
        alpha, beta = z[..., 1::2], z[..., 2::2]
        shifted[..., 1::2] = alpha * self.cos - beta * self.sin
        shifted[..., 2::2] = alpha * self.sin + beta * self.cos
        return shifted
