"""Any SUMO network drawn (issue 53): the streets and junctions around a route in the replay and the figures, the
traffic lights the route meets recorded in ``signals.csv`` and drawn as stop lines; the paper's roads unchanged."""

from __future__ import annotations

import csv
import json
import math
from itertools import pairwise
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import shapely

from agentic_mpc.geometry import LanePath
from agentic_mpc.plots.network import NetworkDrawing, network_near, sumo_network_near
from agentic_mpc.plots.road import sumo_network_and_road
from agentic_mpc.replay import load_run
from agentic_mpc.run.files import SIGNAL_COLUMNS, SIGNALS
from agentic_mpc.run.signal_log import STATES, UNOBSERVED, SignalLog, stop_line_pose
from agentic_mpc.world.lanes import RoadLanes
from agentic_mpc.world.observation import EgoObservation, JunctionAhead, Observation
from tests.run.conftest import short_run

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = Path("/usr/bin/chromium")


@pytest.fixture(scope="module")
def cross_run(tmp_path_factory) -> Path:
    """SUMO's crossroad, straight on, seed 0: 50 s after the 60 s warm-up; the ego waits at red, goes on green."""
    return short_run(tmp_path_factory, "junction_cross.yaml", "straight", 110.0)


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def _net(run_dir: Path):
    simulation = json.loads((run_dir / "scenario.json").read_text())["simulation"]
    return simulation, sumo_network_and_road(simulation)[0].net


# ---------------------------------------------------------------- signals.csv


def test_signals_csv_holds_each_change_of_the_light_at_the_stop_line(cross_run):
    with open(cross_run / SIGNALS, newline="") as handle:
        assert tuple(next(csv.reader(handle))) == SIGNAL_COLUMNS
    rows = _rows(cross_run / SIGNALS)
    assert {r["state"] for r in rows} <= set(STATES)
    assert [r["junction_id"] for r in rows] == ["0"] * len(rows)  # the one light on the way (m1 has none)
    states = [r["state"] for r in rows]
    assert states == ["red", "green", UNOBSERVED]  # a row per change only: red, the switch to green, left behind
    times = [float(r["time_s"]) for r in rows]
    assert times == sorted(times) and times[0] < 60.2 and 85.0 < times[1] < 95.0
    # the stop line: where the ego's lane (1si_1, the middle of three) ends at the junction, pointing along it
    _, net = _net(cross_run)
    lane = net.getLane("1si_1").getShape()
    for r in rows:
        assert (float(r["x_m"]), float(r["y_m"])) == pytest.approx(lane[-1], abs=0.05)
        assert float(r["heading_rad"]) == pytest.approx(math.atan2(lane[-1][1] - lane[0][1],
                                                                   lane[-1][0] - lane[0][0]), abs=0.002)
    # what the junction log saw agrees: the ego stood while red, went in on green, after the switch
    trajectory = _rows(cross_run / "trajectory.csv")
    red = [t for t in trajectory if times[0] <= float(t["time_s"]) < times[1]]
    assert min(float(t["v_mps"]) for t in red) < 0.1
    assert max(float(t["x_m"]) for t in red) < float(rows[0]["x_m"])  # never past the line on red
    entered = next(e for e in _rows(cross_run / "events.csv") if e["event"] == "junction_entered"
                   and e["content"] == "0")
    assert json.loads(entered["result"])["signal"] == "green" and float(entered["sim_time_s"]) > times[1]
    # the ego's centre drives over the recorded line
    xy = np.array([[float(t["x_m"]), float(t["y_m"])] for t in trajectory])
    assert np.hypot(*(xy - lane[-1]).T).min() < 0.5


def _ego(road_s_m: float, x_m: float = 0.0, y_m: float = 0.0, lane_index: int = 0) -> EgoObservation:
    return EgoObservation("ego", x_m, y_m, 0.0, 5.0, "e_0", lane_index, "center", "e", road_s_m, 0.0, 5.0, 2.0)


def _observation(time_s: float, *junctions: JunctionAhead, road_s_m: float = 0.0) -> Observation:
    return Observation(time_s, _ego(road_s_m), (), (), (), (), tuple(junctions))


def _junction(junction_id: str, stop_s_m: float, signal: str | None) -> JunctionAhead:
    return JunctionAhead(junction_id, stop_s_m, stop_s_m + 15.0, stop_s_m, "straight", signal, False, False, None)


def test_signal_log_writes_a_row_only_when_a_light_changes():
    path = LanePath([(0.0, 0.0), (100.0, 0.0), (100.0, 100.0)])
    lanes = RoadLanes({"center": path}, 13.9, False, (path,), (0,))
    log = SignalLog(lambda: lanes)
    sequence = [("red", "green"), ("red", "green"), ("green", "green"), ("green", "yellow"), ("green", None)]
    for step, (first, second) in enumerate(sequence):
        ahead = [_junction("A", 50.0, first)]
        if second is not None:
            ahead.append(_junction("B", 150.0, second))
        log.observe(_observation(step * 0.5, *ahead, road_s_m=step))
    log.observe(_observation(3.0, _junction("C", 170.0, None)))  # no light: no rows
    assert [(r["time_s"], r["junction_id"], r["state"]) for r in log.rows] == [
        (0.0, "A", "red"), (0.0, "B", "green"), (1.0, "A", "green"), (1.5, "B", "yellow"),
        (2.0, "B", UNOBSERVED), (3.0, "A", UNOBSERVED)]
    a, b = log.rows[0], log.rows[1]
    assert (a["x_m"], a["y_m"], a["heading_rad"]) == (50.0, 0.0, 0.0)  # on the route's one lane at stop_s
    assert (b["x_m"], b["y_m"], b["heading_rad"]) == pytest.approx((100.0, 50.0, math.pi / 2), abs=1e-4)


def test_stop_line_on_a_carriageway_follows_the_egos_lane():
    lanes = [LanePath([(0.0, y), (300.0, y)]) for y in (-3.5, 0.0, 3.5)]
    road = RoadLanes({"right": lanes[0], "center": lanes[1], "left": lanes[2]}, 30.0, False, tuple(lanes), (2, 1, 0))
    ego = _ego(road_s_m=40.0, x_m=42.0, y_m=3.4, lane_index=2)  # the ego's s runs 2 m behind its lane's
    assert stop_line_pose(road, ego, 100.0) == pytest.approx((102.0, 3.5, 0.0))


# ---------------------------------------------------------------- the replay's scene


def test_the_replay_draws_the_streets_junctions_and_lights_around_the_route(cross_run):
    scene = load_run(cross_run)
    road = scene["road"]
    assert len(road["lanes"]) == 1 and len(road["edges"]) == 2  # the route, as before
    network = road["network"]
    simulation, net = _net(cross_run)
    track = np.array([[p[1], p[2]] for p in scene["ego"]["track"]])
    reach = shapely.buffer(shapely.LineString(track), 150.0 + 0.5)
    # every drawn point lies within 150 m of the ego's path
    points = [p for _, lines in network["lanes"] for line in lines for p in line]
    points += [p for line in network["dividers"] for p in line] + [p for ring in network["junctions"] for p in ring]
    assert all(reach.contains(shapely.Point(p)) for p in points)
    # the other streets: each drawn line lies on a lane of the net, and every lane near the path is drawn
    widths = [width for width, _ in network["lanes"]]
    assert widths == [3.2]  # all the net's lanes are 3.2 m wide
    drawn = [shapely.LineString(line) for _, lines in network["lanes"] for line in lines]
    lanes = [shapely.LineString(lane.getShape()) for edge in net.getEdges(withInternal=False)
             for lane in edge.getLanes()]
    assert all(min(max(lane.distance(shapely.Point(p)) for p in line.coords) for lane in lanes) < 0.15
               for line in drawn)
    near = [lane for lane in lanes if lane.distance(shapely.LineString(track)) < 140.0]
    assert len(near) == 18  # all 22 but the far ends of the north and south arms (3fi, 3fo, 4fi, 4fo)
    assert all(any(line.length > 10.0 and max(lane.distance(shapely.Point(p)) for p in line.coords) < 0.15
                   for line in drawn) for lane in near)
    north = max(points, key=lambda p: p[1])  # the north arm is cut 150 m from the path
    assert shapely.Point(north).distance(shapely.LineString(track)) == pytest.approx(150.0, abs=0.5)
    # the junctions: the crossroad's shape (an area as the net's) and the four joints of its arms
    rings = [shapely.Polygon(ring) for ring in network["junctions"]]
    crossroad = next(r for r in rings if r.centroid.distance(shapely.Point(200.0, 200.0)) < 2.0)
    assert crossroad.area == pytest.approx(shapely.Polygon(net.getNode("0").getShape()).area, rel=0.02)
    assert len(rings) == 4  # 0, m1, m2, m4 (m3 lies further than 150 m)
    assert len(network["dividers"]) == 6  # between the three lanes in of each of three arms in the box
    # the lights: junction 0 red, then green, then behind the ego, at its stop line
    assert [(s["id"], [c[1] for c in s["changes"]]) for s in scene["signals"]] == [
        ("0", ["red", "green", UNOBSERVED])]
    assert scene["signals"][0]["changes"][0][2:] == [184.01, 195.49, 0.07]
    assert len(json.dumps(network, separators=(",", ":"))) < 3000  # a few kilobytes
    # the cache of the figures and the replay agree
    assert sumo_network_near(simulation, reach)


@pytest.mark.parametrize("net, road", [("emergency_lefthand", "emergency"), ("emergency", "emergency"),
                                       ("curvy", "curvy"), ("straight", "straight"),
                                       ("lampilot_motorway", "lampilot_motorway"),
                                       ("lampilot_motorway_lefthand", "lampilot_motorway")])
def test_the_paper_roads_have_no_network_to_draw(net, road):
    simulation = {"net_file": str(ROOT / "sumo_nets" / f"{net}.net.xml"), "road": road}
    assert not sumo_network_near(simulation, shapely.box(-1e5, -1e5, 1e5, 1e5))


def test_a_paper_run_replays_its_road_as_before(emergency_run):
    scene = load_run(emergency_run)
    road = scene["road"]
    assert set(road) == {"lanes", "boundaries", "edges", "lane_width_m"}  # no network
    assert scene["signals"] == [] and not (emergency_run / SIGNALS).exists()
    # three lanes 3.75 m apart, their boundaries half way between, the edges outside: as the road draws them
    firsts = sorted(line[0][1] for line in road["lanes"])
    assert np.diff(firsts) == pytest.approx([3.75, 3.75], abs=0.3)
    bounds = sorted(line[0][1] for line in road["boundaries"])
    assert bounds == pytest.approx([(firsts[0] + firsts[1]) / 2, (firsts[1] + firsts[2]) / 2], abs=0.05)
    edges = sorted(side[0][0][1] for side in road["edges"])
    assert edges == pytest.approx([firsts[0] - road["lane_width_m"] / 2, firsts[2] + road["lane_width_m"] / 2],
                                  abs=0.3)


def test_network_near_leaves_out_what_the_road_draws(cross_run):
    _, net = _net(cross_run)
    everything = network_near(net, shapely.box(-1e4, -1e4, 1e4, 1e4))
    arm = [lane.getID() for edge in ("1si", "1o") for lane in net.getEdge(edge).getLanes()]
    without = network_near(net, shapely.box(-1e4, -1e4, 1e4, 1e4), arm)
    assert len(everything.lanes) == 22 and len(without.lanes) == 18  # 3 + 1 lanes of the west arm left out
    assert len(everything.dividers) == 6 and len(without.dividers) == 4  # the west arm's two
    assert len(everything.junctions) == 5 and len(without.junctions) == 5  # m1 joins 1si/1o and 1fi/1fo too
    back = NetworkDrawing.from_json(everything.to_json())
    assert [w for w, _ in back.lanes] == [w for w, _ in everything.lanes]
    assert len(back.surface_outlines) == 22 + 5


# ---------------------------------------------------------------- the figures


def test_the_figure_zooms_to_the_light_and_draws_its_stop_line_red(cross_run):
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Polygon

    from agentic_mpc.plots.drawing import SIGNAL_COLOURS, road_lines
    from agentic_mpc.plots.panels import draw_panel
    from agentic_mpc.plots.places import zoom_windows
    from agentic_mpc.plots.runs import network_of, plotted_run

    run = plotted_run(cross_run)
    window = next(w for w in zoom_windows([run]) if w.lead.kind == "waiting at a light")
    assert window.lead.label == "waiting at a light: 0"
    red = float(run.signals["time_s"].iloc[0]), float(run.signals["time_s"].iloc[1])
    assert red[0] <= window.lead.t < red[1]
    assert window.contains(184.01, 195.49)  # the stop line is in the window
    assert window.across[1] - window.across[0] >= 24.0  # wide enough for the crossing street
    assert run.lights_at(window.lead.t) == [(184.01, 195.49, 0.07, "red")]
    assert run.lights_at(95.0) == [(184.01, 195.49, 0.07, "green")]
    road = {**road_lines(list(run.road.lanes().lanes.values())), "network": network_of([run])}
    fig, ax = plt.subplots()
    drawn = draw_panel(ax, window, road, [run], "tab:green", run)
    assert "stop line" in drawn
    bars = [p for p in ax.patches if isinstance(p, Polygon) and p.get_facecolor()[:3] == pytest.approx(
        tuple(int(SIGNAL_COLOURS["red"][i:i + 2], 16) / 255 for i in (1, 3, 5)))]
    assert len(bars) == 1
    surfaces = [c for c in ax.collections if isinstance(c, PolyCollection)]
    assert surfaces and len(surfaces[0].get_paths()) >= 5  # lanes and the crossroad near the window
    plt.close(fig)
    assert (cross_run / "trajectory.png").stat().st_size > 0


# ---------------------------------------------------------------- the page in a browser


def _pixels(page, points: list[tuple[float, float]]) -> list[tuple[int, int, int]]:
    return [tuple(rgb) for rgb in page.evaluate("""(points) => {
        const v = document.getElementById('view'), s = window.replayState, px = s.scale * (window.devicePixelRatio || 1);
        return points.map(([x, y]) => Array.from(v.getContext('2d').getImageData(
            Math.round(v.width / 2 + (x - s.ego.x) * px), Math.round(v.height / 2 - (y - s.ego.y) * px), 1, 1).data)
            .slice(0, 3));
    }""", points)]


def test_the_page_draws_the_junction_and_the_stop_line_in_its_colour(cross_run):
    if not CHROMIUM.is_file():
        pytest.skip(f"{CHROMIUM} is missing: install Debian's chromium")
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is missing: pip install -e '.[test]'")
    rows = _rows(cross_run / SIGNALS)
    line = (float(rows[0]["x_m"]), float(rows[0]["y_m"]))
    heading = float(rows[0]["heading_rad"])
    across = [(line[0] - math.sin(heading) * d, line[1] + math.cos(heading) * d) for d in (-1.0, 0.0, 1.0)]
    with sync_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=str(CHROMIUM), args=["--no-sandbox", "--disable-gpu"])
        page = browser.new_page(viewport={"width": 1400, "height": 820})
        errors: list[str] = []
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.goto((cross_run / "replay.html").as_uri())
        page.wait_for_function("window.replayState !== undefined")
        changes = [float(r["time_s"]) for r in rows]
        for state, colour, start, end in (("red", (220, 38, 38), changes[0], changes[1]),
                                          ("green", (34, 197, 94), changes[1], changes[2])):
            seen = []  # the bar's pixels at 8 moments (a car crossing the line covers it now and then)
            for t in np.linspace(start + 0.3, end - 0.3, 8):
                assert page.evaluate(f"window.replaySeek({t})")["signals"] == [{"id": "0", "state": state}]
                seen += _pixels(page, across)
            assert sum(rgb == colour for rgb in seen) >= len(seen) / 2, (state, seen)
            assert not any(rgb == other for rgb in seen for other in ((220, 38, 38), (34, 197, 94)) if other != colour)
        # the crossroad and the arms north and south of it are paved (asphalt, not grass)
        paved = [(200.0, 200.0), (195.0, 215.0), (205.0, 185.0), (196.0, 230.0), (203.0, 170.0), (210.0, 205.0)]
        assert sum(rgb == (75, 85, 99) for rgb in _pixels(page, paved)) >= 4
        assert page.evaluate(f"window.replaySeek({float(rows[2]['time_s']) + 0.5})")["signals"] == []
        browser.close()
    assert errors == []


# ---------------------------------------------------------------- an OpenStreetMap route


@pytest.mark.slow  # about 20 s: the first 180 s of the 2.8 km route through an OpenStreetMap import
def test_an_openstreetmap_route_replays_its_streets_and_lights(tmp_path_factory):
    run_dir = short_run(tmp_path_factory, "junction_osm_route.yaml", None, 300.0)
    rows = _rows(run_dir / SIGNALS)
    by_junction: dict[str, list[dict[str, str]]] = {}
    for r in rows:
        by_junction.setdefault(r["junction_id"], []).append(r)
    assert len(by_junction) >= 3
    trajectory = np.array([[float(t["x_m"]), float(t["y_m"])] for t in _rows(run_dir / "trajectory.csv")])
    for junction_id, changes in by_junction.items():
        states = [r["state"] for r in changes]
        assert all(a != b for a, b in pairwise(states)), (junction_id, states)  # changes only
        if states[-1] == UNOBSERVED:  # passed: the ego's centre went over its stop line
            x, y = float(changes[0]["x_m"]), float(changes[0]["y_m"])
            assert np.hypot(trajectory[:, 0] - x, trajectory[:, 1] - y).min() < 1.5, junction_id
    scene = load_run(run_dir)
    network = scene["road"]["network"]
    assert len(network["junctions"]) > 50 and sum(len(lines) for _, lines in network["lanes"]) > 200
    assert len(json.dumps(network, separators=(",", ":"))) < 100_000
    assert {s["id"] for s in scene["signals"]} == set(by_junction)


def test_live_scene_sends_the_signals_as_they_come():
    from agentic_mpc.replay.live import LiveScene

    recorder = SimpleNamespace(trajectory_rows=[], traffic_rows=[], received_calls=[],
                               metrics=SimpleNamespace(obstacles=[]), signals=SimpleNamespace(rows=[]))
    loop = SimpleNamespace(recorder=recorder, agent=None, world=SimpleNamespace(
        observation=SimpleNamespace(ego=SimpleNamespace(x_m=0.0, y_m=0.0))))
    live = LiveScene(loop, {"name": "x", "variant": "v", "seed": 0})
    row = {"time_s": 1.0, "junction_id": "J", "state": "red", "stop_s_m": 50.0, "x_m": 50.0, "y_m": 0.0,
           "heading_rad": 0.0}
    recorder.signals.rows.append(row)
    first = live.initial()
    assert first["signals"] == [{"id": "J", "changes": [[1.0, "red", 50.0, 0.0, 0.0]]}]
    since = LiveScene.counts_of(first)
    assert since["signals"] == 1
    recorder.signals.rows.append({**row, "time_s": 9.0, "state": "green"})
    new, counts = live.chunk(since)
    assert new["signals"] == [["J", 9.0, "green", 50.0, 0.0, 0.0]] and counts["signals"] == 2
    assert live.chunk(counts)[0]["signals"] == []
