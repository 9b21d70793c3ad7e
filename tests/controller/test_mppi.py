"""Fourier MPPI: the fast path equals the NumPy reference; the controller never outputs NaN."""

import math

import numpy as np
import pytest

from agentic_mpc import vehicle
from agentic_mpc.controller import FourierMPPI, MPPIConfig
from agentic_mpc.geometry import LanePath
from agentic_mpc.primitives import (
    Blockage,
    Circle,
    FollowingDistance,
    LaneLines,
    Leader,
    Mandatory,
    MovingDisc,
    ObstacleAvoidance,
    PathTracking,
    PreferredSteeringDirection,
    Specification,
    Surroundings,
    TrackingReference,
)
from agentic_mpc.vehicle import VEHICLE_MODELS, VehicleParams

CURVE = LanePath(np.column_stack([np.linspace(0, 300, 301), 20 * np.sin(np.linspace(0, 300, 301) / 60)]))


def specifications():
    j1 = PathTracking(path=CURVE, v_ref_mps=15)
    j2 = ObstacleAvoidance(obstacles=(Circle(x_m=25, y_m=8, radius_m=2), Circle(x_m=10, y_m=1, radius_m=1.5)))
    return {
        "J0": Specification.of(),
        "J0+J1": Specification.of(j1),
        "paper J1+J2": Specification.of(j1.model_copy(update={"reference_accel_mps2": None}), j2),
        "J1+J2+J3 lateral": Specification.of(j1, j2, PreferredSteeringDirection(direction="right")),
        "J3 paper, no path": Specification.of(PreferredSteeringDirection(direction="left", form="paper")),
        "J3 lateral, no path": Specification.of(PreferredSteeringDirection(direction="left")),
        "J0 with rate term": Specification.of(Mandatory(input_rate_weight=5.0, speed_limit_mps=14.0), j1),
        "J0 time gap 2 s, 5 m": Specification.of(Mandatory(time_gap_s=2.0, standstill_gap_m=5.0, time_gap_weight=3.0), j1),
        "J0 time gap off": Specification.of(Mandatory(time_gap_weight=0.0), j1),
        "J1 lateral weight": Specification.of(j1.model_copy(update={"lateral_weight": 6.0}), j2),
        "J1+J4 following distance": Specification.of(j1, FollowingDistance(gap_m=8.0)),
        # at 14 m/s no plan stands: count every plan that ends below 20 m/s as standing
        "J0 lane lines": Specification.of(Mandatory(lane_line_standing_mps=20.0), j1),
    }


def surroundings(horizon):
    k = np.arange(1, horizon + 1)[:, None]
    ahead = np.hstack([20 + 12 * 0.04 * k, np.full_like(k, 3.0, dtype=float)])
    edge = TrackingReference(
        np.column_stack([np.linspace(0, 30, horizon), np.full(horizon, 5.0)]), np.tile([1.0, 0.0], (horizon, 1))
    )
    right = TrackingReference(edge.points - [0, 10.0], edge.tangents)
    # Two leaders: one 14 m ahead at 10 m/s (the samples at 14 m/s fall short of the time gap), one on a bend.
    leader = Leader(np.hstack([16 + 10 * 0.04 * k, np.full_like(k, 1.0, dtype=float)]), np.tile([1.0, 0.0], (horizon, 1)))
    angle = np.linspace(0.0, 0.4, horizon)[:, None]
    bend = Leader(np.hstack([30 + 20 * np.sin(angle), 1 + 20 * (1 - np.cos(angle))]), np.hstack([np.cos(angle), np.sin(angle)]),
                  queue_lateral_m=2.4)  # driving up to a blockage: room wanted behind it
    # Two blockages: one in line 38 m ahead (inside the room plus stopping distance from 14 m/s), one ahead
    # and to the left that only some samples end in line with.
    blockages = (Blockage(40.0, 1.0, 1.0, 0.0, 2.4), Blockage(25.0, 4.5, 0.995, 0.0998, 2.4, -1.3))
    # A car changing lanes to the left alongside at 0.15 rad: its cover grows with the ego's angle against it.
    changing = np.hstack([3 + 12.5 * 0.04 * k, 4.0 + 1.6 * 0.04 * k])
    turned = MovingDisc(changing, 2.55, np.tile([np.cos(0.15), np.sin(0.15)], (horizon, 1)), (2.6, 0.95), 2.4)
    # A car coming from behind in the lane to the left, 2.5 m beside.
    follower = MovingDisc(np.hstack([-4 + 16 * 0.04 * k, np.full_like(k, 3.5, dtype=float)]), 2.6,
                          np.tile([1.0, 0.0], (horizon, 1)), (2.3, 0.9), 2.3)
    discs = (MovingDisc(ahead, 2.5), turned, follower)
    # Lines between lanes at 1.75 m left and right of a reference line that bends left (every 1 m, 40 m on)
    along = np.linspace(0.0, 39.0, 40)
    bend_angle = along / 150.0
    lines = LaneLines(np.column_stack([150 * np.sin(bend_angle), 150 * (1 - np.cos(bend_angle))]),
                      np.column_stack([np.cos(bend_angle), np.sin(bend_angle)]), 1.0, (-1.75, 1.75), 2.3, 0.9)
    return Surroundings(moving_discs=discs, road_left_edge=edge, road_right_edge=right,
                        leaders=(leader, bend), blockages=blockages, lane_lines=lines)


@pytest.mark.parametrize("name", list(specifications()))
@pytest.mark.parametrize("horizon, samples", [(50, 256), (17, 64)])
@pytest.mark.parametrize("plant", ["paper", "urban"])  # urban: steering past the short tan series' range
def test_fast_path_equals_reference(name, horizon, samples, plant):
    spec = specifications()[name]
    controller = FourierMPPI(MPPIConfig(horizon=horizon, samples=samples), params=VEHICLE_MODELS[plant], seed=5)
    controller.mean = np.random.default_rng(1).normal(size=controller.mean.shape) * 0.4
    controller.previous_input = (0.2, -0.1)
    state = np.array([2.0, 1.0, 0.1, 14.0])
    prepared = spec.prepare(controller.context(state, surroundings(horizon)))
    z = controller.sample().copy()
    fast, used_fast = controller.costs(prepared, state, z)
    assert used_fast
    reference = prepared.cost(controller.rollouts(state, z))
    assert np.allclose(fast, reference, rtol=1e-10, atol=1e-10)
    weights_fast = controller.weights(fast.copy()).weights
    weights_ref = controller.weights(reference).weights
    assert np.allclose(np.einsum("s,ics->ic", weights_fast, z), np.einsum("s,ics->ic", weights_ref, z), atol=1e-10)


@pytest.mark.parametrize("plant", ["paper", "urban"])
def test_fast_and_reference_controllers_drive_identically(plant):
    spec = specifications()["J1+J2+J3 lateral"]
    outputs = {}
    for backend in ("fast", "reference"):
        controller = FourierMPPI(MPPIConfig(backend=backend), params=VEHICLE_MODELS[plant], seed=11)
        state = np.array([0.0, 0.0, 0.0, 15.0])
        outputs[backend] = [controller.step(state, spec).inputs for _ in range(5)]
    assert np.allclose(outputs["fast"], outputs["reference"], atol=1e-9)


def test_same_seed_same_inputs_different_seed_different_inputs():
    spec = specifications()["J0+J1"]
    state = np.array([0.0, 0.5, 0.0, 15.0])
    runs = [[FourierMPPI(seed=s).step(state, spec).inputs for _ in range(1)] for s in (4, 4, 5)]
    assert np.array_equal(runs[0], runs[1])
    assert not np.array_equal(runs[0], runs[2])


@pytest.mark.parametrize(
    "state",
    [
        [1e6, -1e6, 0.0, 15.0],
        [0.0, 0.0, 1e3, 15.0],
        [0.0, 0.0, 0.0, 500.0],
        [0.0, 0.0, 0.0, 0.0],
        [0.0, 1e4, -3.0, 1e4],
    ],
)
def test_extreme_states_never_give_nan_inputs(state):
    controller = FourierMPPI(seed=0)
    for spec in specifications().values():
        for _ in range(3):
            out = controller.step(np.array(state), spec)
            assert np.all(np.isfinite(out.inputs))
            assert -1 <= out.delta <= 1 and 0 <= out.throttle <= 1 and 0 <= out.brake <= 1


def test_nan_state_is_refused_with_a_clear_error():
    with pytest.raises(ValueError, match="state must be 4 finite numbers"):
        FourierMPPI().step(np.array([0.0, np.nan, 0.0, 1.0]), Specification.of())


def test_weights_survive_non_finite_costs():
    controller = FourierMPPI()
    weighting = controller.weights(np.array([np.inf, 3.0, np.nan, 4.0]))
    weights = weighting.weights
    assert weights is not None and np.isclose(weights.sum(), 1.0) and weights[0] == 0 and weights[2] == 0
    assert weighting.cost_min == 3.0
    assert controller.weights(np.array([np.nan, np.inf])).weights is None


def test_a_plant_that_steers_further_than_the_fast_path_handles_is_refused():
    with pytest.raises(ValueError, match="road-wheel angle"):
        FourierMPPI(MPPIConfig(), params=VehicleParams(r_delta=1.0, l_r_m=1.5, l_f_m=1.5))


def test_the_urban_plant_turns_at_junctions_and_the_papers_does_not():
    """Full lock at 5 m/s for 4 s: the paper's identified model turns on a 32 m radius, the urban one on 4.8 m."""
    radii = {}
    for name, params in VEHICLE_MODELS.items():
        state = np.array([0.0, 0.0, 0.0, 5.0])
        for _ in range(100):
            state = vehicle.step(state, 1.0, vehicle.throttle_for_steady_speed(5.0), 0.0, params)
        radii[name] = params.l_r_m / math.sin(vehicle.slip_angle(1.0, params))
        assert state[2] == pytest.approx(4.0 * 5.0 / radii[name], rel=0.02)
    assert radii["paper"] == pytest.approx(32.1, abs=0.2) and radii["urban"] == pytest.approx(4.8, abs=0.1)


def test_config_is_validated():
    with pytest.raises(ValueError, match="even"):
        MPPIConfig(samples=255)
    with pytest.raises(ValueError, match="temperature"):
        MPPIConfig(temperature=0)


def test_the_recorded_plan_starts_where_the_applied_input_takes_the_car():
    from agentic_mpc.vehicle import step as vehicle_step

    controller = FourierMPPI(seed=3)
    state = np.array([0.0, 0.2, 0.0, 14.0])
    lane = LanePath.straight((-20.0, 0.0), (400.0, 0.0), name="center")
    out = controller.step(state, Specification.of(PathTracking(path=lane, lane="center", v_ref_mps=15.0)))
    plan = controller.planned_states(state)
    assert plan.shape == (controller.config.horizon, 4)
    np.testing.assert_allclose(plan[0], vehicle_step(state, out.delta, out.throttle, out.brake, controller.params),
                               atol=1e-9)
    assert np.all(np.diff(plan[:, 0]) > 0)  # it drives on along the lane


@pytest.mark.parametrize("noise", ["pinned", "paper"])
@pytest.mark.parametrize("antithetic, include_mean", [(True, True), (False, False), (True, False)])
def test_compiled_sampling_equals_the_numpy_definition(noise, antithetic, include_mean):
    settings = {"first_input_noise": noise, "antithetic": antithetic, "include_mean": include_mean, "samples": 64}
    fast = FourierMPPI(MPPIConfig(**settings), seed=9)
    reference = FourierMPPI(MPPIConfig(backend="reference", **settings), seed=9)
    mean = np.random.default_rng(2).normal(size=fast.mean.shape)
    fast.mean, reference.mean = mean, mean.copy()
    for _ in range(3):  # same draws from the same generator, the same samples
        np.testing.assert_allclose(fast.sample(), reference.sample(), rtol=0, atol=1e-13)


@pytest.mark.parametrize(
    "costs",
    [
        np.random.default_rng(4).exponential(5.0, 256) + 30.0,
        np.r_[np.inf, np.nan, np.random.default_rng(5).normal(0.0, 100.0, 254)],
        np.r_[np.full(255, np.inf), 7.0],
        np.full(256, np.nan),
    ],
    ids=["spread", "some non-finite", "one finite", "none finite"],
)
@pytest.mark.parametrize("band", [(0.05, 0.2), None])
def test_compiled_weighting_equals_the_numpy_definition(costs, band):
    fast = FourierMPPI(MPPIConfig(ess_band=band, temperature=2.0), seed=1)
    reference = FourierMPPI(MPPIConfig(ess_band=band, temperature=2.0, backend="reference"), seed=1)
    z = np.random.default_rng(6).normal(size=(2, 9, 256))
    (w_fast, mean_fast), (w_ref, mean_ref) = fast.average(costs.copy(), z), reference.average(costs.copy(), z)
    assert w_fast.found == w_ref.found == np.isfinite(costs).any()
    if w_ref.found:
        np.testing.assert_allclose(w_fast.weights, w_ref.weights, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(mean_fast, mean_ref, rtol=1e-12, atol=1e-13)
        assert w_fast.temperature == pytest.approx(w_ref.temperature, rel=1e-12)
        assert w_fast.effective_samples == pytest.approx(w_ref.effective_samples, rel=1e-12)
        assert w_fast.cost_min == w_ref.cost_min


def test_compiled_start_and_shift_equal_the_fourier_module():
    from agentic_mpc.controller import coefficient_kernels, fourier

    z = np.random.default_rng(7).normal(size=(2, 9))
    shift = fourier.OneStepShift(4, 50)
    shifted = np.empty_like(z)
    starts = coefficient_kernels.start_and_shift(z, shift.cos, shift.sin, shifted)
    assert np.array_equal(starts, fourier.value_at_start(z))  # bitwise: the applied input is the reference's
    assert np.array_equal(shifted, shift(z))
