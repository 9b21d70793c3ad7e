"""The scene a replay is made of, read back from real runs' files."""

import csv
import math

import pytest

from agentic_mpc.replay import ReplayInputError, load_run


def _trajectory(run_dir):
    with open(run_dir / "trajectory.csv", newline="") as handle:
        return list(csv.DictReader(handle))


def test_plain_run_scene(plain_run):
    scene = load_run(plain_run)
    rows = _trajectory(plain_run)
    track = scene["ego"]["track"]
    assert track[0][0] == pytest.approx(float(rows[0]["time_s"]))
    assert track[-1][0] == pytest.approx(float(rows[-1]["time_s"]), abs=1e-3)  # the last step is kept
    assert 40 <= len(track) <= len(rows)  # ~20 Hz from 25 Hz
    assert track[0][1:4] == [pytest.approx(float(rows[0][k]), abs=0.01) for k in ("x_m", "y_m", "phi_rad")]
    assert track[0][4] == pytest.approx(15.0, abs=0.01)
    # the plain road: three lanes 3.5 m apart along +x, edges half a lane outside, cropped near the run
    lanes = scene["road"]["lanes"]
    assert sorted(line[0][1] for line in lanes) == [-3.5, 0.0, 3.5]
    assert [side[0][0][1] for side in scene["road"]["edges"]] == [5.25, -5.25]
    assert all(line[-1][0] - line[0][0] < 600 for line in lanes)  # not the whole 20 km road
    assert scene["road"]["lane_width_m"] == 3.5
    assert scene["obstacles"] == [{"id": "obstacle", "discs": [[45.0, 0.0, 2.0]]}]
    kinds = [c["kind"] for c in scene["captions"]]
    assert "passenger" in kinds and "tool" in kinds
    tool = next(c for c in scene["captions"] if c["kind"] == "tool")
    assert tool["text"] == "set_preferred_steering_direction(direction=right)"
    assert "preferred_steering_direction(direction=right)" in scene["ego"]["specs"][-1][2]
    assert scene["notes"] == []
    # the run recorded the MPPI plan every 25 steps: H = 50 points starting just ahead of the ego
    plan_rows = list(csv.DictReader((plain_run / "plan.csv").open()))
    assert len(plan_rows) == 50 * len(range(0, len(rows), 25))
    first = [r for r in plan_rows if r["time_s"] == rows[0]["time_s"]]
    assert [int(r["k"]) for r in first] == list(range(1, 51))
    assert 0.0 < float(first[0]["x_m"]) - float(rows[0]["x_m"]) < 1.0  # one step of 0.04 s at 15 m/s
    assert float(first[-1]["x_m"]) - float(rows[0]["x_m"]) == pytest.approx(15.0 * 2.0, abs=5.0)
    assert len(scene["plan"]) > 0


def test_emergency_run_scene(emergency_run):
    scene = load_run(emergency_run)
    vehicles = {v["id"]: v for v in scene["traffic"]["vehicles"]}
    ambulance = vehicles["ambulance"]
    assert ambulance["em"] and ambulance["cls"] == "emergency"
    assert (ambulance["L"], ambulance["W"]) == (6.5, 2.2)  # from the route file's vType
    assert (vehicles["block_left"]["L"], vehicles["block_left"]["W"]) == (4.5, 1.8)
    assert (scene["ego"]["L"], scene["ego"]["W"]) == (5.2, 2.0)
    frames = scene["traffic"]["frames"]
    gaps = [b[0] - a[0] for a, b in zip(frames, frames[1:])]
    assert min(gaps) >= 0.1 - 1e-6  # at most 10 Hz
    assert frames[-1][0] > 14.0
    # the ambulance starts ~90 m behind the ego and ends ahead of it
    first = next(row for row in frames[0][1] if row[0] == ambulance_index(scene))
    assert first[1] < scene["ego"]["track"][0][1] - 50
    last = next(row for row in frames[-1][1] if row[0] == ambulance_index(scene))
    assert last[1] > scene["ego"]["track"][-1][1]
    # the road: the three lanes of the left-hand net, 3.75 m apart, with two dashed boundaries
    assert len(scene["road"]["lanes"]) == 3 and len(scene["road"]["boundaries"]) == 2
    assert scene["road"]["lane_width_m"] == pytest.approx(3.75, abs=0.3)
    # the ego stops for the ambulance: acceleration negative then speed near zero
    speeds = [p[4] for p in scene["ego"]["track"]]
    assert min(speeds) < 1.0 and min(p[5] for p in scene["ego"]["track"]) < -1.0
    passenger = [c for c in scene["captions"] if c["kind"] == "passenger"]
    assert passenger[0]["t"] == pytest.approx(1.0) and "ambulance" in passenger[0]["text"]
    tools = [c["text"] for c in scene["captions"] if c["kind"] == "tool"]
    assert tools[0].startswith("run_left_lane(")
    assert [s[2].split("(")[1].split(",")[0] for s in scene["ego"]["specs"]][:2] == ["lane=center", "lane=left"]


def ambulance_index(scene):
    return next(i for i, v in enumerate(scene["traffic"]["vehicles"]) if v["id"] == "ambulance")


def test_plan_csv_is_read_when_present(plain_run, tmp_path):
    import shutil

    run = tmp_path / "run"
    shutil.copytree(plain_run, run)
    with open(run / "plan.csv", "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["time_s", "k", "x_m", "y_m", "ref_x_m", "ref_y_m"])
        for t in (0.0, 0.04, 0.2):
            for k in range(3):
                writer.writerow([t, k, 10 * t + k, 0.1 * k, 10 * t + k, 0.0])
    plan = load_run(run)["plan"]
    assert [step[0] for step in plan] == [0.0, 0.2]  # thinned to 10 Hz
    assert plan[1][1] == [[2.0, 0.0], [3.0, 0.1], [4.0, 0.2]] and len(plan[1][2]) == 3


def test_truncated_run_replays_up_to_its_end(emergency_run, tmp_path):
    import shutil

    run = tmp_path / "crashed"
    shutil.copytree(emergency_run, run)
    for name in ("trajectory.csv", "traffic.csv", "events.csv"):
        text = (run / name).read_text()
        (run / name).write_text(text[: int(len(text) * 0.6)])  # cut mid-line, as a crash leaves it
    scene = load_run(run)
    assert 5.0 < scene["ego"]["track"][-1][0] < 12.0
    assert any("trajectory.csv" in note for note in scene["notes"])
    assert all(math.isfinite(p[1]) for p in scene["ego"]["track"])


def test_not_a_run(tmp_path):
    with pytest.raises(ReplayInputError, match="trajectory.csv"):
        load_run(tmp_path)
    (tmp_path / "trajectory.csv").write_text("time_s,x_m\n")
    with pytest.raises(ReplayInputError, match="trajectory.csv"):
        load_run(tmp_path)
    (tmp_path / "trajectory.csv").write_text("")
    with pytest.raises(ReplayInputError, match="trajectory.csv"):
        load_run(tmp_path)
