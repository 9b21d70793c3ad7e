"""The figures (agentic_mpc.plots) and ``agentic-mpc plot`` on synthetic run and batch directories."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from matplotlib.patches import Polygon

from agentic_mpc import plots
from agentic_mpc.cli import main
from agentic_mpc.geometry import LanePath
from agentic_mpc.plots import demo_figures, drawing, figures
from agentic_mpc.plots.demo_figures import _draw_lanes
from agentic_mpc.plots.drawing import footprint, road_lines
from agentic_mpc.plots.places import find_events, zoom_windows
from agentic_mpc.plots.runs import plotted_run
from agentic_mpc.primitives import Circle
from agentic_mpc.run.files import EVENT_COLUMNS, TRAFFIC_COLUMNS
from agentic_mpc.run.metrics import MetricsRecorder, ObstacleTrack
from agentic_mpc.world.lanes import RoadLanes

PLAIN_WORLD = {"road": {"start_x_m": -20.0, "length_m": 420.0}, "obstacles": [{"id": "obstacle", "x_m": 45.0, "y_m": 0.0}]}


class FakeWorld:
    """A lanes source: three straight lanes ``width`` apart (listed out of order)."""

    def __init__(self, width: float = 3.2) -> None:
        def lane(y: float, name: str) -> LanePath:
            return LanePath.straight((-20.0, y), (400.0, y), name=name)

        self._lanes = RoadLanes({"left": lane(width, "left"), "right": lane(-width, "right"), "center": lane(0.0, "c")},
                                25.0)

    def lanes(self) -> RoadLanes:
        return self._lanes


def write_run(directory: Path, variant_shift_m: float = 0.0, ambulance: bool = True,
              ambulance_speed_mps: float = 20.0) -> Path:
    """A run directory as the recorder writes it (no scenario.json)."""
    directory.mkdir(parents=True, exist_ok=True)
    t = np.arange(0.0, 8.0, 0.1)
    x = 15.0 * t
    y = variant_shift_m * np.sin(np.pi * t / 8.0)
    pd.DataFrame({"time_s": t, "x_m": x, "y_m": y, "v_mps": 15.0 + 0.1 * np.sin(t), "v_ref_mps": 15.0,
                  "road_s_m": x, "tracked_lane_offset_m": y, "lateral_offset_m": y}).to_csv(
        directory / "trajectory.csv", index=False)
    traffic = pd.DataFrame(
        [{"time_s": s, "id": "ambulance", "type_id": "emergency", "vclass": "emergency",
          "x_m": ambulance_speed_mps * s - 60.0, "y_m": 0.0, "heading_rad": 0.0, "speed_mps": ambulance_speed_mps,
          "lane_id": "e_1", "road_s_m": ambulance_speed_mps * s - 60.0,
          "gap_m": 1.0, "relation": "behind", "emergency": True} for s in t[::5]] if ambulance else [],
        columns=list(TRAFFIC_COLUMNS))
    traffic.to_csv(directory / "traffic.csv", index=False)
    call = {"event": "tool_call", "sim_time_s": 1.0, "tool": "set_preferred_steering_direction",
            "arguments": '{"direction": "left"}', "apply_at_s": 1.5}
    pd.DataFrame([call], columns=list(EVENT_COLUMNS)).to_csv(directory / "events.csv", index=False)
    pd.DataFrame([("obstacle", 45.0, 0.0, 2.0)], columns=["id", "x_m", "y_m", "radius_m"]).to_csv(
        directory / "obstacles.csv", index=False)
    return directory


def write_scenario(directory: Path, variant: str, world: dict) -> None:
    scenario = {"name": directory.parent.parent.name, "variant": variant, "seed": 0, "simulation": None,
                "plain_world": None, **world}
    (directory / "scenario.json").write_text(json.dumps(scenario), encoding="utf-8")


def solid_and_dashed(ax) -> tuple[list[np.ndarray], list[np.ndarray]]:
    lines = ax.get_lines()
    return ([line.get_xydata() for line in lines if line.get_linestyle() == "-"],
            [line.get_xydata() for line in lines if line.get_linestyle() == "--"])


def test_one_palette_paper_colours_first_then_the_others_in_order():
    variants = ["dense", "light", "message_left", "no_message"]
    assert plots.colour_of("message_left", variants) == "tab:blue"
    assert plots.colour_of("no_message", variants) == plots.colour_of("unaware", variants) == "0.35"
    assert [plots.colour_of(v, variants) for v in ("dense", "light")] == list(plots.PALETTE[:2])


@pytest.mark.parametrize("width", [3.2, 4.0])
def test_road_edges_are_the_outermost_lanes_shifted_by_half_the_measured_lane_width(width):
    fig, ax = plt.subplots()
    _draw_lanes(ax, list(FakeWorld(width).lanes().lanes.values()))
    edges, centres = solid_and_dashed(ax)
    plt.close(fig)
    assert len(centres) == 3
    assert sorted(float(edge[0, 1]) for edge in edges) == pytest.approx([-1.5 * width, 1.5 * width])


def test_a_single_lane_gets_the_default_width():
    fig, ax = plt.subplots()
    _draw_lanes(ax, [LanePath.straight((0.0, 0.0), (0.0, 100.0), name="north")])  # heading +y: left is -x
    edges, _ = solid_and_dashed(ax)
    plt.close(fig)
    assert sorted(float(edge[0, 0]) for edge in edges) == pytest.approx([-1.75, 1.75])


def test_run_figure_draws_the_world_lanes_and_the_recorded_obstacles(tmp_path, monkeypatch):
    run = write_run(tmp_path / "run", variant_shift_m=2.0)
    metrics = MetricsRecorder(obstacles=[ObstacleTrack("o", (Circle(x_m=45.0, y_m=0.0, radius_m=2.0),), 45.0, 1)])
    drawn, save = {}, drawing.save

    def keep(fig, path, dpi):
        drawn["fig"] = fig
        return save(fig, path, dpi)

    monkeypatch.setattr(figures, "save", keep)
    path = plots.run_figure(run, FakeWorld(), metrics, title="synthetic")
    assert path == run / "trajectory.png" and path.stat().st_size > 10_000
    fig = drawn["fig"]
    overview = fig.axes[0]
    assert len([line for line in overview.get_lines() if line.get_linestyle() == ":"]) == 3  # the lane centres
    assert fig.get_suptitle() == "synthetic"
    assert {label.get_text() for label in overview.get_legend().get_texts()} >= {"ego", "emergency vehicle"}
    panels = [ax for ax in fig.axes[1:] if ax.get_aspect() == 1.0]
    assert panels and all(len(ax.patches) >= 2 for ax in panels)  # footprints (body and windscreen) in each
    assert any("[1] " in ax.get_title(loc="left") for ax in panels)
    texts = [t.get_text() for ax in fig.axes for t in ax.texts]
    assert any("set_preferred_steering_direction(direction:left)" in t for t in texts)


def test_run_figure_without_a_road_or_traffic(tmp_path):
    run = write_run(tmp_path / "run", ambulance=False)
    assert plots.run_figure(run, None, MetricsRecorder()).is_file()


def test_batch_figures_per_scenario_with_the_road_from_road_of(tmp_path):
    for variant, shift in (("message_left", 2.0), ("message_right", -2.0), ("custom", 0.5)):
        write_run(tmp_path / "runs" / "steering" / variant / "seed-0", shift)
    write_run(tmp_path / "runs" / "roadless" / "v" / "seed-0")
    asked = []

    def road_of(run_dir: Path):
        asked.append(run_dir.parent.parent.name)
        return FakeWorld() if "steering" in str(run_dir) else None

    written = plots.batch_figures(tmp_path, road_of)
    assert [p.name for p in written] == ["roadless_trajectories.png", "roadless_timeseries.png",
                                         "steering_trajectories.png", "steering_timeseries.png"]
    assert sorted(asked) == ["roadless", "steering"] and all(p.stat().st_size > 10_000 for p in written)


def test_birds_eye_and_time_series_for_the_demo(tmp_path):
    t = np.linspace(0.0, 5.0, 50)
    states = np.column_stack([15.0 * t, np.sin(t), np.zeros_like(t), np.full_like(t, 15.0)])
    lanes = [LanePath.straight((0.0, 0.0), (100.0, 0.0)), LanePath.straight((0.0, 3.5), (100.0, 3.5))]
    trajectories = {"no_message": [states], "message_left": [states + [0, 1, 0, 0]], "other": [states]}
    out = plots.birds_eye(trajectories, lanes, [Circle(x_m=45.0, y_m=0.0, radius_m=2.0)], tmp_path / "a" / "b.png",
                          x_range_m=(0.0, 110.0))
    series = {variant: [(t, s[:, 3], s[:, 1])] for variant, [s] in trajectories.items()}
    out_t = plots.time_series(series, tmp_path / "t.png", v_ref_mps=15.0, events_s=[(1.0, "message")])
    assert out.stat().st_size > 10_000 and out_t.stat().st_size > 10_000


def test_birds_eye_without_a_range_zooms_to_the_obstacle_and_draws_the_ego_where_it_passes(tmp_path, monkeypatch):
    t = np.linspace(0.0, 20.0, 200)
    states = np.column_stack([15.0 * t, np.zeros_like(t), np.zeros_like(t), np.full_like(t, 15.0)])
    lanes = [LanePath.straight((0.0, 0.0), (400.0, 0.0)), LanePath.straight((0.0, 3.5), (400.0, 3.5))]
    drawn, save = {}, drawing.save

    def keep(fig, path, dpi):
        drawn["ax"] = fig.axes[0]
        return save(fig, path, dpi)

    monkeypatch.setattr(demo_figures, "save", keep)
    plots.birds_eye({"no_message": [states]}, lanes, [Circle(x_m=200.0, y_m=3.5, radius_m=2.0)], tmp_path / "b.png")
    x0, x1 = drawn["ax"].get_xlim()
    assert x0 <= 200.0 <= x1 and x1 - x0 < 100  # not the 300 m driven
    body = next(p for p in drawn["ax"].patches if isinstance(p, Polygon))
    assert body.get_xy()[:4, 0].mean() == pytest.approx(200.0, abs=1.6)  # the ego alongside the obstacle


def test_the_road_is_rebuilt_from_the_saved_scenario_of_a_plain_world_or_a_sumo_road(tmp_path):
    run = write_run(tmp_path / "runs" / "s" / "v" / "seed-0")
    write_scenario(run, "v", {"plain_world": PLAIN_WORLD})
    assert set(plotted_run(run).road.lanes().lanes) == {"left", "center", "right"}
    net = Path(__file__).resolve().parents[1] / "sumo_nets" / "straight.net.xml"
    write_scenario(run, "v", {"simulation": {"net_file": str(net), "road": "straight"}})
    sumo = plotted_run(run).road
    assert isinstance(sumo.lanes(), RoadLanes) and sumo.lanes().speed_limit_mps > 0
    assert set(sumo.lanes().lanes) >= {"left", "right"} and len(sumo.left_to_right) == len(sumo.widths_m)
    write_scenario(run, "v", {})
    assert plotted_run(run).road is None
    assert [len(o.discs) for o in plotted_run(run).obstacles] == [1]


def test_plot_command_on_a_run_and_on_a_batch(tmp_path, capsys):
    for variant in ("no_message", "message_left"):
        run = write_run(tmp_path / "runs" / "plain" / variant / "seed-0", 1.0)
        write_scenario(run, variant, {"plain_world": PLAIN_WORLD})
    assert main(["plot", str(tmp_path)]) == 0
    assert (tmp_path / "plain_trajectories.png").is_file() and (tmp_path / "plain_timeseries.png").is_file()
    (run / "trajectory.png").unlink(missing_ok=True)
    assert main(["plot", str(run)]) == 0
    assert (run / "trajectory.png").stat().st_size > 10_000
    assert main(["plot", str(tmp_path / "runs")]) == 2
    assert "neither a run" in capsys.readouterr().err


def test_nothing_imports_the_plots_at_package_import_time():
    code = ("import sys, agentic_mpc, agentic_mpc.cli, agentic_mpc.scenario.runner, agentic_mpc.commands.plot; "
            "print('agentic_mpc.plots' in sys.modules, 'matplotlib' in sys.modules)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split()[0] == "False"


def test_the_package_and_its_road_load_no_matplotlib_until_a_figure_is_asked_for():
    # the replay page rebuilds the road through agentic_mpc.plots.road and draws in the browser
    code = ("import sys, agentic_mpc.plots, agentic_mpc.plots.road, agentic_mpc.replay.data; "
            "print('matplotlib' in sys.modules); from agentic_mpc.plots import run_figure; "
            "print('matplotlib' in sys.modules, run_figure.__module__)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["False", "True", "agentic_mpc.plots.figures"]


def test_zoom_windows_hold_the_obstacle_and_the_ambulance_pass_and_are_much_smaller_than_the_road(tmp_path):
    run = plotted_run(write_run(tmp_path / "run", variant_shift_m=2.0, ambulance_speed_mps=30.0))  # passes at t = 4 s
    kinds = {e.kind: e for e in find_events(run)}
    assert kinds["ambulance passes"].t == pytest.approx(4.0, abs=0.6) and kinds["obstacle"].x == 45.0
    road = road_lines(list(FakeWorld().lanes().lanes.values()))
    windows = zoom_windows([run], road["edges"])
    road_length = 420.0
    obstacle_window = next(w for w in windows if any(e.kind == "obstacle" for e in w.events))
    assert obstacle_window.contains(45.0, 0.0) and obstacle_window.contains(45.0, 2.0)
    assert obstacle_window.length_m < road_length / 5
    width = obstacle_window.across[1] - obstacle_window.across[0]
    assert 3 * 3.2 <= width <= 3 * 3.2 + 8  # the road's three lanes and a margin, not the whole plot
    passing = next(w for w in windows if any(e.kind == "ambulance passes" for e in w.events))
    x_pass = 15.0 * kinds["ambulance passes"].t
    assert passing.contains(x_pass, 0.0) and passing.length_m < road_length / 5
    assert not passing.turned and passing.heading_rad == 0.0  # a road along +x keeps world coordinates


def test_zoom_windows_turn_with_a_diagonal_road_and_an_ambulance_held_up_behind_is_in_its_window(tmp_path):
    run_dir = write_run(tmp_path / "run")  # the ambulance never passes: it is held up 22.5 m behind at the end
    angle = math.radians(30.0)
    for name, columns in (("trajectory.csv", ("x_m", "y_m")), ("traffic.csv", ("x_m", "y_m")),
                          ("obstacles.csv", ("x_m", "y_m"))):
        table = pd.read_csv(run_dir / name)
        x, y = table[columns[0]].to_numpy(), table[columns[1]].to_numpy()
        table[columns[0]] = x * math.cos(angle) - y * math.sin(angle)
        table[columns[1]] = x * math.sin(angle) + y * math.cos(angle)
        table.to_csv(run_dir / name, index=False)
    run = plotted_run(run_dir)
    held = next(e for e in find_events(run) if e.kind == "ambulance held up")
    windows = zoom_windows([run])
    window = next(w for w in windows if held in w.events)
    ambulance = run.traffic.iloc[-1]
    assert window.turned and window.heading_rad == pytest.approx(angle, abs=0.02)
    assert window.contains(ambulance["x_m"], ambulance["y_m"]) and window.contains(held.x, held.y)
    _, v = window.view(np.array([[held.x, held.y]]))[0]
    assert abs(v) < 1.0  # across the turned view the ego is near the middle


def test_footprints_are_the_vehicles_real_rectangles_turned_with_their_heading():
    fig, ax = plt.subplots()
    body, screen = footprint(ax, lambda xy: xy, 10.0, 5.0, math.pi / 2, 6.5, 2.2, "emergency")
    plt.close(fig)
    corners = body.get_xy()[:4]
    assert np.ptp(corners[:, 1]) == pytest.approx(6.5) and np.ptp(corners[:, 0]) == pytest.approx(2.2)
    assert corners.mean(axis=0) == pytest.approx([10.0, 5.0])
    assert screen.get_xy()[:4, 1].mean() > 5.0  # the windscreen is at the front (heading +y)
    assert body.get_facecolor()[:3] == pytest.approx((0xDC / 255, 0x26 / 255, 0x26 / 255))


def test_batch_figure_has_a_row_of_zoomed_panels_per_variant(tmp_path, monkeypatch):
    for variant, shift in (("message_left", 2.0), ("message_right", -2.0)):
        write_run(tmp_path / "runs" / "steering" / variant / "seed-0", shift, ambulance_speed_mps=30.0)
    drawn, save = [], drawing.save

    def keep(fig, path, dpi):
        drawn.append(fig)
        return save(fig, path, dpi)

    monkeypatch.setattr(figures, "save", keep)
    written = plots.batch_figures(tmp_path, lambda _: FakeWorld())
    trajectories = drawn[0]
    panels = list(trajectories.axes[1:])
    columns = {round(ax.get_position().x0, 3) for ax in panels}
    assert len(panels) == 2 * len(columns) and len(columns) >= 1  # two variants x the places
    assert {ax.get_ylabel() for ax in panels if ax.get_ylabel()} == {"message left", "message right"}
    for ax in panels:
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        assert x1 - x0 < 100 and y1 - y0 < 25  # zoomed: tens of metres, not the 420 m road
    assert written[0].stat().st_size > 20_000
