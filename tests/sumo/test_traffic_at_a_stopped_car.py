"""SUMO's own traffic on the curved road (no ego) passes a car stopped on the curve under the sublane model.

With SUMO's default lane-change parameters its sublane model (on in every rescue-lane scenario) lets the
drivers queued behind a stopped car and those beside them wait for each other: a queue that barely moves, and
in the incident scenario an ego queued in it for good. The route files' ``lcImpatience`` lets them merge
(docs/traffic.md). Real SUMO, the shipped route file against the same file without that attribute.
"""

from __future__ import annotations

import re
from pathlib import Path

import libsumo
import pytest

from agentic_mpc.sumo.bridge import SumoBridge
from agentic_mpc.sumo.scenarios import nets_dir

NETS = nets_dir()
STOPPED_POS_M = 700.0  # the incident scenario's car on the curve
STANDING_MPS = 0.1
STEP_S = 0.1  # coarser than the scenarios' 0.04 s: the queue forms alike, in a third of the time


def _traffic_past_a_stopped_car(route_file: Path, seed: int, duration_s: float = 240.0) -> tuple[int, float, int]:
    """(drivers past the stopped car, the longest any driver stood behind it in s, drivers standing at the end)."""
    passed: set[str] = set()
    standing_s: dict[str, float] = {}
    longest_s = 0.0
    with SumoBridge(NETS / "curvy.net.xml", [route_file], seed=seed, step_length_s=STEP_S,
                    lateral_resolution_m=0.4) as sumo:
        sumo.add_stopped_vehicle("stopped", "road", "obstacle", edge_id="curvy", lane_index=1, pos_m=STOPPED_POS_M)
        while sumo.time_s < duration_s:
            sumo.step()
            for vehicle_id in sumo.vehicle_ids():
                if vehicle_id == "stopped":
                    continue
                pos_m = libsumo.vehicle.getLanePosition(vehicle_id)
                if pos_m > STOPPED_POS_M:
                    passed.add(vehicle_id)
                elif libsumo.vehicle.getSpeed(vehicle_id) < STANDING_MPS and pos_m > STOPPED_POS_M - 150.0:
                    standing_s[vehicle_id] = standing_s.get(vehicle_id, 0.0) + STEP_S
                    longest_s = max(longest_s, standing_s[vehicle_id])
                else:
                    standing_s[vehicle_id] = 0.0
        standing_at_end = sum(1 for v in sumo.vehicle_ids()
                              if v != "stopped" and libsumo.vehicle.getSpeed(v) < STANDING_MPS)
    return len(passed), longest_s, standing_at_end


SEEDS = (0, 1, 2)


@pytest.mark.slow
def test_the_curved_roads_traffic_merges_past_a_stopped_car_under_the_sublane_model(tmp_path, report):
    shipped = NETS / "curvy.rou.xml"
    assert 'lcImpatience="0.5"' in shipped.read_text()
    patient = tmp_path / "curvy_patient.rou.xml"
    patient.write_text(re.sub(r' lcImpatience="[^"]*"', "", shipped.read_text()))

    impatient_runs = [_traffic_past_a_stopped_car(shipped, seed) for seed in SEEDS]
    patient_runs = [_traffic_past_a_stopped_car(patient, seed) for seed in SEEDS]
    for name, runs in (("shipped (lcImpatience 0.5)", impatient_runs), ("without lcImpatience", patient_runs)):
        report(f"curved road, car stopped on the curve, sublane, seeds {SEEDS}, 240 s, {name}: drivers past it"
               f" {[r[0] for r in runs]}, the longest stand {[round(r[1], 1) for r in runs]} s, standing at the"
               f" end {[r[2] for r in runs]}")
    assert max(r[1] for r in impatient_runs) <= 10.0
    assert sum(r[2] for r in impatient_runs) <= 3
    # the patient drivers' queue barely moves: fewer get past, and some stand for half a minute
    assert sum(r[0] for r in impatient_runs) >= sum(r[0] for r in patient_runs) + 30
    assert max(r[1] for r in patient_runs) >= 20.0
