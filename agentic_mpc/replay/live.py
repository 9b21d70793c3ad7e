"""The replay's scene while the run is still going (``agentic-mpc serve --view``).

:class:`LiveScene` reads what the run loop has recorded so far (its recorder's rows, the agent's transcript,
the MCP server's receipts of tool calls) and turns it into the replay page's scene (:mod:`~agentic_mpc.replay
.data`): :meth:`LiveScene.initial` once per page, then :meth:`LiveScene.chunk` with only what is new, which
the page appends (``window.replayAppend``). It runs on the web server's thread and never touches the world
or the controller: it only reads lists the loop appends to (safe under the GIL) and immutable observations.
"""

from __future__ import annotations

import json
import math
import threading
from typing import Any

from agentic_mpc.replay.data import (
    EGO_HZ,
    TRACK_COLUMNS,
    TrafficFrames,
    add_spec,
    captions_of,
    obstacle_items,
    road_geometry,
    rounded,
    scene,
    signal_change,
    signal_items,
)
from agentic_mpc.run.reader import Obstacle, number, run_title, vehicle_sizes

ROAD_MARGIN_M = 5000.0
"""How far around the ego's start the road is drawn on a live page (the replay draws around the whole run)."""
OWN_AGENT_CLIENT = "agentic-mpc-agent"
"""The embedded agent's MCP client name: the server's receipts of its calls are its transcript's calls again."""


def _event_row(record: dict[str, Any]) -> dict[str, Any]:
    """A transcript record or a received call as an ``events.csv`` row (strings for JSON values)."""
    row = dict(record)
    for key in ("arguments", "result"):
        if row.get(key) is not None and not isinstance(row[key], str):
            row[key] = json.dumps(row[key], default=str)
    return {k: ("" if v is None else v) for k, v in row.items()}


class LiveScene:
    """The growing scene of the run ``loop`` (a :class:`~agentic_mpc.run.loop.RunLoop`, read only)."""

    def __init__(self, loop: Any, scenario: dict[str, Any]) -> None:
        self._loop = loop
        self._scenario = scenario
        self._notes: list[str] = []
        self._sizes = vehicle_sizes(scenario, self._notes)
        self._lock = threading.Lock()  # one page's chunk at a time: the cursors are shared
        self._traffic = TrafficFrames(self._sizes)
        self._track: list[list[Any]] = []
        self._specs: list[list[Any]] = []
        self._captions: list[dict[str, Any]] = []
        self._cursor = {"trajectory": 0, "traffic": 0, "transcript": 0, "received": 0}
        self._last_ego_t = -math.inf
        self._road: dict[str, Any] | None = None

    # ------------------------------------------------------------------ what a new page gets
    def initial(self) -> dict[str, Any]:
        """The whole scene so far, in the replay page's format plus ``live: true``."""
        with self._lock:
            self._advance()
            ego = {"columns": list(TRACK_COLUMNS), "track": list(self._track), "specs": list(self._specs)}
            traffic = {"vehicles": list(self._traffic.vehicles.values()), "frames": list(self._traffic.frames)}
            return {"live": True, **scene(self._scenario, self._sizes, run_title(self._scenario), summary={},
                                          road=self._road_near_ego(), ego=ego, traffic=traffic,
                                          obstacles=self._obstacles(), captions=list(self._captions), plan=[],
                                          signals=signal_items(self._signal_rows(0)), notes=list(self._notes))}

    def chunk(self, since: dict[str, int]) -> tuple[dict[str, Any], dict[str, int]]:
        """What a page that has seen ``since`` (the counts of a previous chunk) has not: new track points,
        traffic frames, vehicles, specifications and captions; and the counts to pass next time."""
        with self._lock:
            self._advance()
            frames = self._traffic.frames
            counts = {"track": len(self._track), "frames": len(frames), "vehicles": len(self._traffic.vehicles),
                      "specs": len(self._specs), "captions": len(self._captions)}
            signals = self._signal_rows(since.get("signals", 0))
            counts["signals"] = since.get("signals", 0) + len(signals)
            vehicles = list(self._traffic.vehicles.values())
            new = {
                "track": self._track[since.get("track", 0):], "frames": frames[since.get("frames", 0):],
                "vehicles": vehicles[since.get("vehicles", 0):], "specs": self._specs[since.get("specs", 0):],
                "captions": self._captions[since.get("captions", 0):],
                "signals": [[str(row["junction_id"]), *signal_change(row)] for row in signals],
            }
        return new, counts

    @staticmethod
    def counts_of(scene: dict[str, Any]) -> dict[str, int]:
        """The counts of what :meth:`initial` gave (to ask :meth:`chunk` for the rest)."""
        return {"track": len(scene["ego"]["track"]), "frames": len(scene["traffic"]["frames"]),
                "vehicles": len(scene["traffic"]["vehicles"]), "specs": len(scene["ego"]["specs"]),
                "captions": len(scene["captions"]),
                "signals": sum(len(junction["changes"]) for junction in scene.get("signals", []))}

    # ------------------------------------------------------------------ reading the loop
    def _take(self, name: str, rows: list[Any]) -> list[Any]:
        start = self._cursor[name]
        new = rows[start:]  # a copy: the loop may append meanwhile
        self._cursor[name] = start + len(new)
        return new

    def _advance(self) -> None:
        recorder = self._loop.recorder
        for row in self._take("trajectory", recorder.trajectory_rows):
            self._ego_row(row)
        for row in self._take("traffic", recorder.traffic_rows):
            self._traffic.add(row)
        agent = getattr(self._loop, "agent", None)
        records = [_event_row(r) for r in self._take("transcript", agent.transcript.records if agent else [])]
        records += [_event_row(r) for r in self._take("received", recorder.received_calls)
                    if not str(r.get("client", "")).startswith(OWN_AGENT_CLIENT)]
        records.sort(key=lambda r: number(r.get("sim_time_s"), 0.0))
        self._captions.extend(captions_of(records, own_calls=False))

    def _ego_row(self, row: dict[str, Any]) -> None:
        t = float(row["time_s"])
        add_spec(self._specs, t, str(row.get("spec_version", "")), str(row.get("spec_summary", "")))
        if t - self._last_ego_t < 1.0 / EGO_HZ - 1e-6:
            return
        v = float(row["v_mps"])
        previous = self._track[-1] if self._track else None
        moved = previous is not None and t > previous[0] and previous[4] is not None
        accel = (v - previous[4]) / (t - previous[0]) if moved else 0.0
        self._track.append([rounded(t, 3), rounded(float(row["x_m"])), rounded(float(row["y_m"])),
                            rounded(float(row["phi_rad"]), 3), rounded(v), rounded(accel)])
        self._last_ego_t = t

    def _signal_rows(self, start: int) -> list[dict[str, Any]]:
        """The rows of ``signals.csv`` the recorder has kept so far, from the ``start``-th on."""
        signals = getattr(self._loop.recorder, "signals", None)
        return list(signals.rows[start:]) if signals is not None else []

    def _obstacles(self) -> list[dict[str, Any]]:
        tracks = self._loop.recorder.metrics.obstacles
        return obstacle_items([Obstacle(track.id, tuple((c.x_m, c.y_m, c.radius_m) for c in track.circles))
                               for track in tracks if track.circles], self._sizes)

    def _road_near_ego(self) -> dict[str, Any]:
        if self._road is None:
            ego = self._loop.world.observation.ego
            box = (ego.x_m - ROAD_MARGIN_M, ego.y_m - ROAD_MARGIN_M, ego.x_m + ROAD_MARGIN_M, ego.y_m + ROAD_MARGIN_M)
            try:
                self._road = road_geometry(self._scenario, box)
            except Exception as error:  # the scene without a road beats no scene
                self._notes.append(f"road not drawn: {type(error).__name__}: {error}")
                self._road = {}
        return self._road
