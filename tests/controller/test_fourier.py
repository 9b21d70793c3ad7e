import numpy as np
import pytest

from agentic_mpc.controller import fourier


def test_synthesis_is_the_printed_series():
    order, horizon = 4, 50
    rng = np.random.default_rng(3)
    z = rng.normal(size=2 * order + 1)
    k = np.arange(horizon)
    expected = z[0] + sum(
        z[2 * l - 1] * np.sin(2 * np.pi * l * k / horizon) + z[2 * l] * np.cos(2 * np.pi * l * k / horizon)
        for l in range(1, order + 1)
    )
    assert np.allclose(z @ fourier.basis(order, horizon), expected, atol=1e-13)
    assert fourier.value_at_start(z) == pytest.approx(expected[0])


def test_paper_standard_deviations():
    assert np.allclose(fourier.coefficient_std(0.8, 0.8, 4), [0.8, 0.64, 0.64, 0.512, 0.512, 0.4096, 0.4096, 0.32768, 0.32768])
    assert fourier.coefficient_std(0.3, 0.8, 4)[0] == 0.3


def test_shift_advances_the_series_by_one_step():
    horizon = 40
    z = np.random.default_rng(0).normal(size=9)
    u = z @ fourier.basis(4, horizon)
    shifted = fourier.shift_one_step(z, horizon) @ fourier.basis(4, horizon)
    assert np.allclose(shifted, np.roll(u, -1), atol=1e-12)
