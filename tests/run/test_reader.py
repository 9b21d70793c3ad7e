"""The one reader of a run directory, on a real short run's files (and copies of them cut or broken)."""

from __future__ import annotations

import shutil

import pandas as pd
import pytest

from agentic_mpc.plots.road import run_road
from agentic_mpc.run import files
from agentic_mpc.run.reader import (
    DEFAULT_SIZES,
    Obstacle,
    RunDirectory,
    RunDirectoryError,
    is_emergency,
    read_run,
    size_of,
)


def test_a_real_run_reads_back_as_rows_tables_scenario_and_obstacles(plain_run):
    run = read_run(plain_run)
    rows = run.rows(files.TRAJECTORY)
    table = run.table(files.TRAJECTORY)
    assert len(rows) == len(table) >= 90  # 4 s at 25 Hz
    assert set(files.EGO_COLUMNS) <= set(rows[0]) == set(table.columns)
    assert float(rows[0]["x_m"]) == table["x_m"].iloc[0]
    assert (run.scenario["name"], run.scenario["variant"], run.scenario["seed"]) == (
        "paper_steering_preference_plain", "message_right", 0)
    assert run.title == "paper_steering_preference_plain / message_right / 0"
    assert run.obstacles == [Obstacle("obstacle", ((45.0, 0.0, 2.0),))]
    assert run.obstacles[0].car(run.sizes) is None  # one disc: no stopped car
    assert run.ego_size == DEFAULT_SIZES["ego"]
    summary = run.summary()
    assert summary is not None and summary["status"] == "ok"
    assert summary == pd.read_csv(plain_run / files.SUMMARY, dtype=str, keep_default_na=False).iloc[0].to_dict()
    events = run.rows(files.EVENTS)
    assert any(r["event"] == "tool_call" for r in events) and list(events[0]) == list(files.EVENT_COLUMNS)
    assert run.rows(files.TRAFFIC) == [] and run.table(files.TRAFFIC).empty  # no traffic in this world
    assert run.notes == []


def test_the_road_of_a_real_run_is_rebuilt_from_its_scenario(plain_run):
    road = run_road(read_run(plain_run).scenario)
    assert [lane.coordinates[0][1] for lane in road.left_to_right] == [3.5, 0.0, -3.5]  # left-hand road: +y left
    assert road.widths_m == (3.5, 3.5, 3.5)
    assert [edge.coordinates[0][1] for edge in road.edges] == [5.25, -5.25]
    assert set(road.lanes().lanes) == {"left", "center", "right"}


def test_a_cut_off_file_reads_up_to_its_last_whole_line_with_a_note(plain_run, tmp_path):
    run_dir = tmp_path / "crashed"
    shutil.copytree(plain_run, run_dir)
    whole = len(read_run(plain_run).rows(files.TRAJECTORY))
    text = (run_dir / files.TRAJECTORY).read_text()
    (run_dir / files.TRAJECTORY).write_text(text[: int(len(text) * 0.5)])  # cut mid-line, as a crash leaves it
    run = read_run(run_dir)
    rows = run.rows(files.TRAJECTORY)
    assert 0 < len(rows) < whole
    assert [note.split(":")[0] for note in run.notes] == [files.TRAJECTORY]


def test_what_is_not_a_run_is_refused(tmp_path):
    with pytest.raises(RunDirectoryError, match="no such directory"):
        read_run(tmp_path / "nowhere")
    with pytest.raises(RunDirectoryError, match="trajectory.csv is missing"):
        read_run(tmp_path)
    (tmp_path / files.TRAJECTORY).write_text("time_s,x_m\n0,0\n")
    with pytest.raises(RunDirectoryError, match=r"missing columns \['y_m', 'phi_rad', 'v_mps'\]"):
        read_run(tmp_path).rows(files.TRAJECTORY)
    run = read_run(tmp_path)
    assert run.scenario == {} and run.notes == ["scenario.json missing: no road drawn"]
    assert run.title == tmp_path.name and run_road(run.scenario) is None


def test_a_summary_is_one_row_or_none(tmp_path):
    assert RunDirectory(tmp_path).summary() is None
    (tmp_path / files.SUMMARY).write_text("scenario,status\na,ok\n")
    assert RunDirectory(tmp_path).summary() == {"scenario": "a", "status": "ok"}
    (tmp_path / files.SUMMARY).write_text("scenario,status\na,ok\nb,ok\n")
    assert RunDirectory(tmp_path).summary() is None


def test_sizes_and_emergency_flags_as_every_reader_finds_them():
    sizes = {"ambulance_type": (7.0, 2.4), "@plain_car": (4.0, 1.9)}
    assert size_of(sizes, "a1", "ambulance_type@route_2", "emergency") == (7.0, 2.4)  # the type before the "@"
    assert size_of(sizes, "plain_car", "", "passenger") == (4.0, 1.9)
    assert size_of(sizes, "t", "unknown", "truck") == DEFAULT_SIZES["truck"]
    flags = (("True", "passenger"), (True, "passenger"), ("false", "emergency"), (False, "passenger"), ("", "bus"))
    assert [is_emergency(flag, cls) for flag, cls in flags] == [True, True, True, False, False]


def test_a_stopped_car_is_where_its_discs_line_up():
    car = Obstacle("parked", ((10.0, 0.0, 1.0), (12.0, 1.0, 1.0), (14.0, 2.0, 1.0))).car({"obstacle": (5.0, 2.0)})
    assert car == pytest.approx((12.0, 1.0, 0.4636476, 5.0, 2.0))
