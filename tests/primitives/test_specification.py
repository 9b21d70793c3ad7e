"""Primitives validate their parameters; the specification is immutable and swaps atomically."""

import threading

import numpy as np
import pytest
from pydantic import ValidationError

from agentic_mpc.geometry import LanePath
from agentic_mpc.primitives import (
    POOL,
    Circle,
    Mandatory,
    ObstacleAvoidance,
    PathTracking,
    PreferredSteeringDirection,
    Specification,
    SpecificationError,
    SpecificationSlot,
    describe_pool,
)

LANE = LanePath.straight((0, 0), (100, 0), name="center")


@pytest.mark.parametrize(
    "build, primitive, field",
    [
        (lambda: PathTracking(path=LANE, v_ref_mps=-1), "PathTracking", "v_ref_mps"),
        (lambda: PathTracking(path=LANE, v_ref_mps=float("nan")), "PathTracking", "v_ref_mps"),
        (lambda: PathTracking(path=[[0, 0]], v_ref_mps=10), "PathTracking", "path"),
        (lambda: PreferredSteeringDirection(direction="up"), "PreferredSteeringDirection", "direction"),
        (lambda: Circle(x_m=0, y_m=0, radius_m=0), "Circle", "radius_m"),
        (lambda: ObstacleAvoidance(obstacles=()), "ObstacleAvoidance", "obstacles"),
        (lambda: Mandatory(speed_limit_mps=float("inf")), "Mandatory", "speed_limit_mps"),
        (lambda: PathTracking(path=LANE, v_ref_mps=5, colour="red"), "PathTracking", "colour"),
    ],
)
def test_invalid_parameters_name_the_primitive_and_field(build, primitive, field):
    with pytest.raises(ValidationError) as error:
        build()
    assert primitive in str(error.value) and field in str(error.value)


def test_primitives_are_immutable():
    j1 = PathTracking(path=LANE, v_ref_mps=10)
    with pytest.raises(ValidationError):
        j1.v_ref_mps = 3  # type: ignore[misc]


def test_attach_replaces_by_name_and_detach_refuses_the_mandatory_part():
    spec = Specification.of(PathTracking(path=LANE, v_ref_mps=15))
    assert spec.names == ("mandatory", "path_tracking")
    left = PathTracking(path=LANE.parallel(3.5), lane="left", v_ref_mps=0)
    changed = spec.attach(left, PreferredSteeringDirection(direction="left"))
    assert changed.names == ("mandatory", "path_tracking", "preferred_steering_direction")
    assert changed.get("path_tracking").lane == "left"
    assert spec.get("path_tracking").lane == "center"  # the original is untouched
    with pytest.raises(SpecificationError, match="mandatory"):
        changed.detach("mandatory")
    with pytest.raises(SpecificationError, match="not attached"):
        spec.detach("preferred_steering_direction")
    assert changed.detach("preferred_steering_direction").names == spec.names


def test_describe_is_json_ready():
    import json

    spec = Specification.of(PathTracking(path=LANE, v_ref_mps=15), ObstacleAvoidance(obstacles=(Circle(x_m=1, y_m=2, radius_m=3),)))
    text = json.dumps(spec.describe())
    assert '"v_ref_mps": 15.0' in text and '"symbol": "J2"' in text
    assert spec.summary() == "path_tracking(lane=center, v_ref_mps=15); obstacle_avoidance(n=1)"
    pool = describe_pool()
    assert [p["kind"] for p in pool] == list(POOL) and pool[0]["mandatory"] is True
    json.dumps(pool)


def test_slot_swaps_are_atomic_under_concurrency():
    """Writers change v_ref and the lane together; readers must never see one without the other."""
    lanes = {"center": LANE, "left": LANE.parallel(3.5)}
    slot = SpecificationSlot(Specification.of(PathTracking(path=LANE, lane="center", v_ref_mps=15)))
    seen_versions = []
    slot.subscribe(lambda spec, version: seen_versions.append(version))
    errors = []
    stop = threading.Event()

    def writer(lane, speed):
        for _ in range(300):
            slot.update(lambda s: s.attach(PathTracking(path=lanes[lane], lane=lane, v_ref_mps=speed)))

    def reader():
        while not stop.is_set():
            j1 = slot.current.get("path_tracking")
            if (j1.lane, j1.v_ref_mps) not in {("center", 15.0), ("left", 0.0)}:
                errors.append((j1.lane, j1.v_ref_mps))

    threads = [threading.Thread(target=writer, args=("left", 0.0)), threading.Thread(target=writer, args=("center", 15.0))]
    readers = [threading.Thread(target=reader) for _ in range(2)]
    for t in readers + threads:
        t.start()
    for t in threads:
        t.join()
    stop.set()
    for t in readers:
        t.join()
    assert not errors
    assert slot.version == 600 and sorted(seen_versions) == list(range(1, 601))


def test_a_failing_change_swaps_nothing():
    slot = SpecificationSlot(Specification.of())
    with pytest.raises(SpecificationError):
        slot.update(lambda s: s.detach("mandatory"))
    assert slot.version == 0 and slot.current is slot.initial


def test_j3_lateral_form_costs_nothing_on_the_lane_and_penalises_the_wrong_side():
    from agentic_mpc.controller import FourierMPPI

    controller = FourierMPPI()
    spec = Specification.of(PathTracking(path=LANE, v_ref_mps=10), PreferredSteeringDirection(direction="left"))
    prepared = spec.prepare(controller.context(np.array([0.0, 0.0, 0.0, 10.0])))
    j3 = prepared.costs[-1]
    from agentic_mpc.primitives import Rollouts

    h = 50
    def rollout_at(y):
        xs = np.tile(np.arange(1, h + 1)[:, None] * 0.4, (1, 3))
        ys = np.tile(np.array(y, dtype=float), (h, 1))
        zero = np.zeros((h, 3))
        return Rollouts(xs, ys, zero, zero + 10, zero, zero, zero, zero, zero)

    cost = j3.cost(rollout_at([0.0, 2.5, -2.5]))
    assert cost[0] == 0 and cost[1] == 0 and cost[2] > 0  # on the lane, left of it, right of it
    assert cost[2] == pytest.approx(0.5 * 200 / h * h * (2.5 - 1.0) ** 2)


def test_j3_lateral_form_charges_going_further_to_the_wrong_side_never_the_way_back():
    """3 m to the unwanted side (after a lane change there): staying costs nothing, coming back nothing, going
    further costs what going as far beyond the dead zone costs on the lane."""
    from agentic_mpc.controller import FourierMPPI
    from agentic_mpc.primitives import Rollouts

    controller = FourierMPPI()
    spec = Specification.of(PathTracking(path=LANE, v_ref_mps=10), PreferredSteeringDirection(direction="left"))
    prepared = spec.prepare(controller.context(np.array([0.0, -3.0, 0.0, 10.0])))
    j3 = prepared.costs[-1]
    h = 50
    xs = np.tile(np.arange(1, h + 1)[:, None] * 0.4, (1, 3))
    ys = np.tile(np.array([-3.0, -1.0, -4.5]), (h, 1))
    zero = np.zeros((h, 3))
    cost = j3.cost(Rollouts(xs, ys, zero, zero + 10, zero, zero, zero, zero, zero))
    assert cost[0] == 0 and cost[1] == 0
    assert cost[2] == pytest.approx(0.5 * 200 / h * h * 0.5**2)


def test_path_tracking_ramp_starts_at_least_at_its_start_speed():
    """From a standstill the reference moves off at 2 m/s (then +3 m/s^2), not from 0; never above v_ref."""
    from agentic_mpc.controller import FourierMPPI

    controller = FourierMPPI()
    standing = np.array([0.0, 0.0, 0.0, 0.0])
    for v_ref, first_speed in ((15.0, 2.0), (1.0, 1.0), (0.0, 0.0)):
        reference = PathTracking(path=LANE, v_ref_mps=v_ref).prepare(controller.context(standing)).reference
        step = 0.04
        expected = (first_speed + (3.0 * step if v_ref > first_speed else 0.0)) * step
        assert reference.points[0, 0] == pytest.approx(expected, abs=1e-9), v_ref
