"""``agentic-mpc check`` rejects what SUMO would choke on, with the YAML path, before any simulator starts:
an impossible lateral resolution, an unknown bluelight parameter, a vehicle type the route files lack."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

NETS = Path(__file__).resolve().parents[2] / "sumo_nets"

BASE = f"""\
name: checks
simulation:
  net_file: {NETS / "emergency.net.xml"}
  route_files: [{NETS / "emergency.rou.xml"}]
  road: emergency
  ego: {{lane: center, pos_m: 150.0, speed_mps: 15.0}}
  vehicles:
    - {{id: ambulance, type_id: ambulance, lane: center, pos_m: 60.0, speed_mps: 20.0}}
specification:
  path_tracking: {{lane: center, v_ref_mps: 15.0}}
duration_s: 10.0
"""


def check(tmp_path: Path, text: str) -> subprocess.CompletedProcess:
    file = tmp_path / "scenario.yaml"
    file.write_text(text, encoding="utf-8")
    return subprocess.run([sys.executable, "-m", "agentic_mpc", "check", str(file)], capture_output=True, text=True, check=False)


def test_the_base_is_valid(tmp_path):
    result = check(tmp_path, BASE)
    assert result.returncode == 0, result.stderr


@pytest.mark.parametrize("value", ["0.0", "-0.4"])
def test_lateral_resolution_must_be_positive(tmp_path, value):
    result = check(tmp_path, BASE.replace("  road: emergency\n", f"  road: emergency\n  lateral_resolution_m: {value}\n"))
    assert result.returncode == 2
    assert "scenario.yaml:6: simulation.lateral_resolution_m: Input should be greater than 0" in result.stderr


def test_lateral_resolution_wider_than_a_lane(tmp_path):
    result = check(tmp_path, BASE.replace("  road: emergency\n", "  road: emergency\n  lateral_resolution_m: 4.0\n"))
    assert result.returncode == 2
    assert "scenario.yaml:6: simulation.lateral_resolution_m: 4.0 m is wider than lane" in result.stderr
    assert "(3.75 m)" in result.stderr
    # the same value is fine when neither the sublane model nor rescue lanes are on
    off = BASE.replace("  road: emergency\n", "  road: emergency\n  lateral_resolution_m: 4.0\n"
                       "  rescue_lanes: {enabled: false}\n")
    assert check(tmp_path, off).returncode == 0


def test_unknown_bluelight_parameter(tmp_path):
    text = BASE.replace(
        "  road: emergency\n",
        "  road: emergency\n  rescue_lanes:\n    emergency_params: {device.bluelight.reaction-probability: 1.0}\n",
    )
    result = check(tmp_path, text)
    assert result.returncode == 2
    assert "scenario.yaml:7: simulation.rescue_lanes.emergency_params: unknown bluelight parameters" in result.stderr
    assert "device.bluelight.reaction-probability" in result.stderr


def test_vehicle_type_missing_from_the_route_files(tmp_path):
    result = check(tmp_path, BASE.replace("type_id: ambulance", "type_id: fire_engine"))
    assert result.returncode == 2
    assert "scenario.yaml:8: simulation.vehicles[0].type_id: vehicle type 'fire_engine' is not defined" in result.stderr


def test_missing_type_in_a_variant_names_the_variant(tmp_path):
    text = BASE + "variants:\n  other:\n    simulation: {ego_type_id: bus}\n"
    result = check(tmp_path, text)
    assert result.returncode == 2
    assert "scenario.yaml:14: variants.other.simulation.ego_type_id: vehicle type 'bus' is not defined" in result.stderr
