"""Numba kernels on the Fourier coefficients, around the fused rollout (``kernels.py``): assembling the samples
from the mean and the noise, and taking u(0) and the one-step shift of the optimum. Each computes what its NumPy
counterpart in ``mppi.py`` / ``fourier.py`` computes, without the temporaries."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, error_model="numpy")
def assemble_samples(noise_map, noise, mean, antithetic, include_mean, z):
    """z = mean + noise_map @ noise, per input, into ``z`` (2, C, S): the noisy half then its mirror image
    (``antithetic``), and sample 0 the unperturbed mean (``include_mean``). ``noise_map`` (2, C, C) is the
    pinned map or diag(std); ``noise`` (2, C, S/2 or S) standard normal. What ``FourierMPPI.sample`` does in
    NumPy, without its temporaries."""
    n_inputs, n_coef, n_noise = noise.shape
    for a in range(n_inputs):
        for c in range(n_coef):
            m = mean[a, c]
            for s in range(n_noise):
                z[a, c, s] = 0.0
            for j in range(n_coef):
                factor = noise_map[a, c, j]
                if factor != 0.0:
                    for s in range(n_noise):
                        z[a, c, s] += factor * noise[a, j, s]
            for s in range(n_noise):
                scaled = z[a, c, s]
                z[a, c, s] = scaled + m
                if antithetic:
                    z[a, c, n_noise + s] = m - scaled
            if include_mean:
                z[a, c, 0] = m


@numba.njit(cache=True, nogil=True, error_model="numpy")
def start_and_shift(z, cos_l, sin_l, shifted):
    """u(0) of each input's series (beta_0 + sum beta_l) and, into ``shifted``, the coefficients advanced by
    one step (each harmonic's (alpha_l, beta_l) rotated by 2 pi l / H): ``fourier.value_at_start`` and
    ``fourier.OneStepShift`` in one call. Returns (delta(0), ab(0))."""
    starts = np.empty(z.shape[0])
    for a in range(z.shape[0]):
        betas = 0.0  # summed before adding beta_0, in NumPy's order, so that u(0) is bitwise the reference's
        shifted[a, 0] = z[a, 0]
        for l in range(cos_l.shape[0]):
            alpha, beta = z[a, 1 + 2 * l], z[a, 2 + 2 * l]
            betas += beta
            shifted[a, 1 + 2 * l] = alpha * cos_l[l] - beta * sin_l[l]
            shifted[a, 2 + 2 * l] = alpha * sin_l[l] + beta * cos_l[l]
        starts[a] = z[a, 0] + betas
    return starts[0], starts[1]
