"""The levers that keep the MPPI average meaningful: pinned first input, harmonic noise, ESS band, elites,
input smoothing; each validated, each with a setting that gives back the paper's plain sampling."""

import numpy as np
import pytest
from pydantic import ValidationError

from agentic_mpc.controller import FourierMPPI, MPPIConfig, fourier, weighting
from agentic_mpc.geometry import LanePath
from agentic_mpc.primitives import Mandatory, PathTracking, Specification

LANE = LanePath.straight((-20.0, 0.0), (600.0, 0.0), name="center")
PAPER = {"first_input_noise": "paper", "harmonic_std_scale": 1.0, "ess_band": None}


def test_pinned_noise_leaves_every_samples_first_input_at_the_means():
    controller = FourierMPPI(MPPIConfig(), seed=2)
    controller.mean = np.random.default_rng(0).normal(size=controller.mean.shape)
    z = controller.sample()
    starts = fourier.value_at_start(np.moveaxis(z, 2, 1))  # (2, S)
    np.testing.assert_allclose(starts, fourier.value_at_start(controller.mean)[:, None] * np.ones_like(starts),
                               atol=1e-12)
    later = (fourier.basis(4, 50).T @ z[0])[10]  # the plans still differ later in the horizon
    assert later.std() > 0.05


def test_pinned_noise_is_the_gaussian_conditioned_on_the_first_input():
    std = fourier.coefficient_std(0.8, 0.8, 4) * np.r_[1.0, np.full(8, 0.2)]
    noise_map = fourier.noise_with_fixed_start(std)
    a = fourier.start_row(4)
    np.testing.assert_allclose(a @ noise_map, 0.0, atol=1e-12)
    sigma = np.diag(std**2)
    conditional = sigma - np.outer(sigma @ a, a @ sigma) / (a @ sigma @ a)
    np.testing.assert_allclose(noise_map @ noise_map.T, conditional, atol=1e-12)


def test_pinned_noise_can_leave_the_level_its_spread():
    std = fourier.coefficient_std(0.8, 0.8, 4) * np.r_[1.0, np.full(8, 0.2)]
    noise_map = fourier.noise_with_fixed_start(std, level_share=0.0)
    np.testing.assert_allclose(fourier.start_row(4) @ noise_map, 0.0, atol=1e-12)
    np.testing.assert_allclose(noise_map[0], np.eye(9)[0] * std[0])  # beta_0 as the paper samples it
    np.testing.assert_allclose(noise_map[1::2], np.diag(std)[1::2])  # the sines untouched
    with pytest.raises(ValueError, match="order >= 1"):
        MPPIConfig(order=0)


def test_paper_sampling_is_one_option_away():
    controller = FourierMPPI(MPPIConfig(samples=20000, **PAPER), seed=1)
    z = controller.sample()
    spread = z[:, :, 1:].std(axis=2)
    expected = np.stack([fourier.coefficient_std(0.8, 0.8, 4), fourier.coefficient_std(0.3, 0.8, 4)])
    np.testing.assert_allclose(spread, expected, rtol=0.03)
    assert fourier.value_at_start(np.moveaxis(z, 2, 1)).std(axis=1) == pytest.approx([1.26, 0.47], rel=0.05)


@pytest.mark.parametrize("spread", [0.01, 1.0, 100.0, 1e4])
def test_temperature_search_lands_in_the_band(spread):
    shifted = np.random.default_rng(3).exponential(spread, 256)
    shifted -= shifted.min()
    temperature, ess = weighting.temperature_for_band(shifted, 1.0, 0.05 * 256, 0.2 * 256)
    assert 0.05 * 256 <= ess <= 0.2 * 256
    weights = np.exp(-shifted / temperature)
    assert (weights.sum() ** 2 / (weights**2).sum()) == pytest.approx(ess)
    # a temperature already in the band is kept: the weighting changes only when it must
    assert weighting.temperature_for_band(shifted, temperature, 0.05 * 256, 0.2 * 256)[0] == temperature


def test_temperature_search_survives_costs_that_cannot_reach_the_band():
    one_finite = np.r_[0.0, np.full(255, np.inf)]
    temperature, ess = weighting.temperature_for_band(one_finite, 1.0, 12.8, 51.2)
    assert np.isfinite(temperature) and ess == pytest.approx(1.0)
    all_equal = np.zeros(256)
    temperature, ess = weighting.temperature_for_band(all_equal, 1.0, 12.8, 51.2)
    assert np.isfinite(temperature) and ess == pytest.approx(256.0)


def test_controller_holds_the_ess_band_and_reports_it():
    controller = FourierMPPI(MPPIConfig(), seed=4)
    spec = Specification.of(PathTracking(path=LANE, lane="center", v_ref_mps=15.0))
    state = np.array([0.0, 0.3, 0.0, 14.0])
    outputs = [controller.step(state, spec) for _ in range(20)]
    for out in outputs:
        assert 0.05 <= out.effective_fraction <= 0.2
        assert out.effective_samples == pytest.approx(out.effective_fraction * 256)
        assert out.temperature > 0


@pytest.mark.parametrize("backend", ["fast", "reference"])
def test_the_band_floor_keeps_a_lone_way_out_from_taking_the_weight(backend):
    """200 still samples at one cost and one that moves at a third of it: the band's floor (5 % of S) keeps most of
    the weight on the still ones."""
    controller = FourierMPPI(MPPIConfig(backend=backend), seed=0)
    costs = np.full(256, 60.0)
    costs[:200] = 42.0
    costs[7] = 14.0
    z = np.zeros((2, controller.config.coefficients, 256))
    z[1, 0, 7] = 1.0  # the throttle level of the way out; the others brake at 0
    band, band_mean = controller.average(costs.copy(), z)
    assert band.effective_samples >= 0.05 * 256 and band_mean[1, 0] < 0.5


def test_elite_samples_get_all_the_weight():
    controller = FourierMPPI(MPPIConfig(elite_samples=10, ess_band=None), seed=0)
    costs = np.random.default_rng(1).uniform(0, 5, 256)
    weights = controller.weights(costs).weights
    assert np.count_nonzero(weights) == 10
    assert set(np.flatnonzero(weights)) == set(np.argsort(costs)[:10])


def test_input_smoothing_low_passes_the_applied_input():
    spec = Specification.of(PathTracking(path=LANE, lane="center", v_ref_mps=15.0))
    state = np.array([0.0, 0.0, 0.0, 10.0])
    raw = FourierMPPI(MPPIConfig(**PAPER), seed=6)
    smooth = FourierMPPI(MPPIConfig(**PAPER, input_smoothing=0.5), seed=6)
    first_raw, first_smooth = raw.step(state, spec), smooth.step(state, spec)
    # same samples, same optimum; from a zero previous input a 0.5 low-pass halves the (unsaturated) command
    np.testing.assert_allclose(smooth.optimum, raw.optimum)
    delta_star, ab_star = fourier.value_at_start(raw.optimum)
    assert first_smooth.delta == pytest.approx(np.clip(0.5 * delta_star, -1, 1))
    assert first_smooth.throttle - first_smooth.brake == pytest.approx(np.clip(0.5 * ab_star, -1, 1))
    assert abs(first_raw.delta) >= abs(first_smooth.delta)


def test_smoothness_terms_make_jumpy_plans_cost_more():
    spec_flat = Specification.of(Mandatory(steer_smoothness_weight=0.0, throttle_brake_smoothness_weight=0.0))
    spec_smooth = Specification.of(Mandatory(steer_smoothness_weight=10.0, throttle_brake_smoothness_weight=1000.0))
    controller = FourierMPPI(MPPIConfig(**PAPER), seed=0)
    state = np.array([0.0, 0.0, 0.0, 10.0])
    z = controller.sample().copy()
    context = controller.context(state)
    flat, _ = controller.costs(spec_flat.prepare(context), state, z)
    flat = flat.copy()
    smooth, _ = controller.costs(spec_smooth.prepare(context), state, z)
    plans = np.einsum("ch,ics->ihs", controller.basis, z)  # (2, H, S) raw commands
    steps = np.diff(plans, axis=1) ** 2
    expected = (10.0 * steps[0].sum(axis=0) + 1000.0 * steps[1].sum(axis=0)) / controller.config.horizon
    np.testing.assert_allclose(smooth - flat, expected, rtol=1e-9)
    assert np.all(expected[1:] > 0)  # sample 0 is the mean, a flat plan here


@pytest.mark.parametrize(
    ("update", "field"),
    [
        ({"ess_band": (0.0, 0.2)}, "ess_band"),
        ({"ess_band": (0.3, 0.2)}, "ess_band"),
        ({"ess_band": (0.1, 1.5)}, "ess_band"),
        ({"elite_samples": 300}, "elite_samples"),
        ({"elite_samples": 0}, "elite_samples"),
        ({"input_smoothing": -0.1}, "input_smoothing"),
        ({"input_smoothing": 1.0}, "input_smoothing"),
        ({"harmonic_std_scale": 0.0}, "harmonic_std_scale"),
        ({"first_input_noise": "none"}, "first_input_noise"),
        ({"pinned_level_share": 1.5}, "pinned_level_share"),
    ],
)
def test_settings_that_cannot_work_are_refused_naming_the_field(update, field):
    with pytest.raises(ValidationError, match=field):
        MPPIConfig(**update)


def test_negative_smoothness_weight_is_refused():
    with pytest.raises(ValidationError, match="throttle_brake_smoothness_weight"):
        Mandatory(throttle_brake_smoothness_weight=-1.0)
