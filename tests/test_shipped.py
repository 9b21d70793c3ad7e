"""Shipped scenarios found by name, a path preferred over a name, and a copy that runs where it is put."""

from __future__ import annotations

import pytest

from agentic_mpc import shipped
from agentic_mpc.commands import scenario_file
from agentic_mpc.scenario.schema import load_scenario


def test_every_shipped_scenario_is_found_by_name_and_loads():
    names = shipped.scenario_names()
    assert {"paper_steering_preference", "paper_emergency_response", "plain_world_traffic"} <= set(names)
    for name in names:
        path = shipped.scenario_path(name)
        assert path == shipped.scenario_path(f"{name}.yaml")
        assert load_scenario(path).base.name == name


def test_a_name_resolves_to_the_shipped_file_and_says_so(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    resolved = shipped.resolve("paper_emergency_response")
    assert resolved.shipped and resolved.path == shipped.scenarios_dir() / "paper_emergency_response.yaml"
    assert resolved.note.startswith("paper_emergency_response: the shipped scenario ")


def test_a_file_here_wins_over_a_shipped_name_and_the_note_says_which(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "paper_emergency_response.yaml").write_text("name: mine\n")
    resolved = shipped.resolve("paper_emergency_response.yaml")
    assert not resolved.shipped and resolved.path.resolve() == tmp_path / "paper_emergency_response.yaml"
    assert "read as the file" in resolved.note and "a shipped scenario has that name too" in resolved.note
    plain = tmp_path / "other.yaml"
    plain.write_text("name: other\n")
    assert shipped.resolve(str(plain)).note is None


def test_an_unknown_name_lists_the_known_ones(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(shipped.UnknownScenario) as error:
        shipped.resolve("paper_emergency")
    assert "no such file, and no shipped scenario of that name" in str(error.value)
    assert "paper_emergency_response" in str(error.value)
    with pytest.raises(shipped.UnknownScenario):
        shipped.scenario_path("../scenarios/paper_emergency_response")  # names only, no paths
    missing = shipped.resolve("somewhere/missing.yaml")  # a path: the loader says it cannot read it
    assert not missing.shipped and missing.path == tmp_path.joinpath("somewhere/missing.yaml").relative_to(tmp_path)
    import argparse

    with pytest.raises(argparse.ArgumentTypeError, match="traffic_density_sweep"):
        scenario_file("nope")
    assert scenario_file("paper_steering_preference") == shipped.scenario_path("paper_steering_preference")
    assert "the shipped scenario" in capsys.readouterr().err


def test_a_copied_scenario_loads_with_its_nets_beside_it_and_is_not_overwritten(tmp_path):
    written = shipped.copy_scenario("emergency_rescue_lane_traffic", tmp_path / "mine")
    scenario_path, nets = written[0], written[1:]
    assert scenario_path == tmp_path / "mine" / "emergency_rescue_lane_traffic.yaml"
    assert sorted(p.name for p in nets) == ["curvy.net.xml", "curvy.rou.xml"]
    text = scenario_path.read_text()
    assert "../sumo_nets/" not in text and "net_file: sumo_nets/curvy.net.xml" in text
    assert "# Scenario 2 in background traffic" in text  # the comments a user edits by survive the copy
    loaded = load_scenario(scenario_path)
    assert loaded.base.simulation.net_file == tmp_path / "mine" / "sumo_nets" / "curvy.net.xml"
    assert loaded.variant_names == load_scenario(shipped.scenario_path("emergency_rescue_lane_traffic")).variant_names
    with pytest.raises(FileExistsError, match="not overwriting"):
        shipped.copy_scenario("emergency_rescue_lane_traffic", tmp_path / "mine")
    plain = shipped.copy_scenario("plain_world_traffic", tmp_path / "plain")
    assert len(plain) == 1 and load_scenario(plain[0]).base.plain_world is not None
