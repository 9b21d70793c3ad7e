"""Scenario files: the shipped ones validate; bad ones fail before any simulation, naming file, line and path."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from agentic_mpc.scenario.schema import load_scenario
from agentic_mpc.scenario.yaml_source import ScenarioFileError

REPO = Path(__file__).resolve().parents[2]
SCENARIOS = sorted((REPO / "scenarios").glob("*.yaml"))


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_shipped_scenarios_validate(path):
    scenario_file = load_scenario(path)
    for name in scenario_file.variant_names:
        scenario = scenario_file.variant(name)
        if scenario.simulation is None:
            assert scenario.plain_world is not None
            continue
        assert scenario.simulation.net_file.is_file()
        assert all(route.is_file() for route in scenario.simulation.route_files)


def test_paper_scenarios_have_the_paper_variants():
    steering = load_scenario(REPO / "scenarios/paper_steering_preference.yaml")
    assert steering.variant_names == ["no_message", "message_right", "message_left"]
    assert "right" in steering.variant("message_right").messages[0].text
    assert steering.variant("no_message").messages == ()
    emergency = load_scenario(REPO / "scenarios/paper_emergency_response.yaml")
    assert set(emergency.variant_names) == {"yield", "no_message"}
    second = emergency.variant("yield").messages[1]
    assert second.event == "emergency_vehicle_passed" and second.text == "Thank you. The ambulance is gone."


def write_variant_of(tmp_path, replacements: dict[str, str], source="paper_steering_preference.yaml") -> Path:
    text = (REPO / "scenarios" / source).read_text()
    for old, new in replacements.items():
        assert old in text, old
        text = text.replace(old, new)
    (tmp_path / "scenarios").mkdir()
    path = tmp_path / "scenarios" / source
    path.write_text(text)
    shutil.copytree(REPO / "sumo_nets", tmp_path / "sumo_nets")  # the file's ../sumo_nets paths stay valid
    return path


def problems_of(path) -> str:
    with pytest.raises(ScenarioFileError) as error:
        load_scenario(path)
    return str(error.value)


def test_every_problem_is_reported_with_file_line_and_path(tmp_path):
    path = write_variant_of(
        tmp_path,
        {
            "duration_s: 12.0": "duration_s: -1\ncolour: red",
            "speed_mps: 15.0}": "speed_mps: fast}",
            "{at_s: 0.2, text: \"Let's try to avoid obstacles from the left, shall we?\"}": "{at_s: 0.2}",
        },
    )
    report = problems_of(path)
    lines = path.read_text().splitlines()
    duration_line = next(i for i, l in enumerate(lines, 1) if l.startswith("duration_s"))
    assert f"{path}:{duration_line}: duration_s: Input should be greater than 0" in report
    assert f"{path}:{duration_line + 1}: colour: Extra inputs are not permitted" in report
    ego_line = next(i for i, l in enumerate(lines, 1) if "ego:" in l)
    assert f"{path}:{ego_line}: simulation.ego.speed_mps: Input should be a valid number" in report
    message_line = next(i for i, l in enumerate(lines, 1) if "{at_s: 0.2}" in l)
    assert f"{path}:{message_line}: variants.message_left.messages[0].text: Field required" in report


def test_message_past_the_end_and_bad_primitive_parameters(tmp_path):
    path = write_variant_of(
        tmp_path,
        {
            "{at_s: 0.2, text: \"Let's try to avoid obstacles from the right, shall we?\"}": "{at_s: 99, text: hi}",
            "path_tracking: {lane: center, v_ref_mps: 15.0}": "path_tracking: {lane: center, v_ref_mps: -3}",
        },
    )
    report = problems_of(path)
    assert "variants.message_right.messages[0].at_s: 99 s is past the end of the run (duration_s = 12.0)" in report
    assert "specification.path_tracking.v_ref_mps: Input should be greater than or equal to 0" in report


def test_missing_files_duplicate_keys_and_syntax_errors(tmp_path):
    path = write_variant_of(tmp_path, {"../sumo_nets/straight.net.xml": "../sumo_nets/nowhere.net.xml"})
    assert "simulation.net_file: file not found" in problems_of(path)
    path.write_text("name: a\nname: b\n")
    assert f"{path}:2: name: duplicate key" in problems_of(path)
    path.write_text("name: [unclosed\n")
    assert "invalid YAML" in problems_of(path)
    assert "cannot read" in problems_of(tmp_path / "absent.yaml")


def test_unknown_variant_is_named():
    scenario_file = load_scenario(REPO / "scenarios/paper_steering_preference.yaml")
    with pytest.raises(ScenarioFileError, match="unknown variant 'sideways'; variants: no_message, message_right"):
        scenario_file.variant("sideways")


def test_check_command_exit_codes(tmp_path):
    ok = subprocess.run([sys.executable, "-m", "agentic_mpc", "check", *map(str, SCENARIOS)], capture_output=True, text=True)
    assert ok.returncode == 0 and ok.stdout.count(": ok") == len(SCENARIOS)
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\n")
    result = subprocess.run([sys.executable, "-m", "agentic_mpc", "check", str(bad)], capture_output=True, text=True)
    assert result.returncode == 2 and "give exactly one world: simulation (SUMO) or plain_world" in result.stderr
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"name: x\n\x00\x01\x02 garbage\n")
    result = subprocess.run([sys.executable, "-m", "agentic_mpc", "check", str(binary)], capture_output=True, text=True)
    assert result.returncode == 2 and f"{binary}: not a YAML text file" in result.stderr
    assert "Traceback" not in result.stderr
    binary.write_bytes(bytes(range(128, 256)))
    result = subprocess.run([sys.executable, "-m", "agentic_mpc", "check", str(binary)], capture_output=True, text=True)
    assert result.returncode == 2 and f"{binary}: not a text file" in result.stderr


def test_each_thing_is_said_once(tmp_path):
    """One v_ref (the specification's), one seed (the run's): the world's config takes neither."""
    path = write_variant_of(tmp_path, {"  ego: {lane: center": "  v_ref_mps: 15.0\n  seed: 3\n  ego: {lane: center"})
    report = problems_of(path)
    assert "simulation.v_ref_mps: Extra inputs are not permitted" in report
    assert "simulation.seed: Extra inputs are not permitted" in report


def test_reading_a_scenario_loads_no_simulator_and_no_controller():
    code = ("import sys, agentic_mpc.scenario.schema as s; s.load_scenario(sys.argv[1]); "
            "print(sorted(m for m in ('libsumo', 'sumolib', 'numba', 'mcp', 'pandas', 'numpy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code, str(SCENARIOS[0])], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
