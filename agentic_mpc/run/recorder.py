"""What a run records, and the files it writes (names and columns in :mod:`agentic_mpc.run.files`):
``trajectory.csv`` (one row per control step, with the motion columns of :mod:`agentic_mpc.run.comfort`),
``traffic.csv`` (the other road users every few steps), ``signals.csv`` (the traffic lights the route meets, a
row when one changes: :mod:`agentic_mpc.run.signal_log`; only a run that met a light has it), ``plan.csv`` (the
controller's optimal predicted trajectory every few steps, when asked for), ``events.csv`` (messages, tool calls,
specification changes, collisions), ``obstacles.csv`` (J2's discs), ``obstacle_passes.csv`` (one row per
obstacle: side, clearance, when passed) and ``summary.csv`` (the metrics of :mod:`agentic_mpc.run.metrics` and
:mod:`agentic_mpc.run.comfort`). :mod:`agentic_mpc.run.reader` reads them back.

A ``collision`` row in ``events.csv`` is one contact episode of the ego (not every step in contact): ``source``
says who saw it first (``sumo`` or ``geometry``), ``content`` the cause and the other vehicle, ``result`` the
same as JSON (``other``, ``other_type``, ``cause``, ``ego_at_fault``, the two speeds). A ``sumo_collision_report``
row is a collision SUMO reported while the two footprints stayed apart (``min_footprint_gap_m``): not counted."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agentic_mpc.primitives import PathTracking, Specification
from agentic_mpc.run import files
from agentic_mpc.run.comfort import add_motion_columns, comfort_summary
from agentic_mpc.run.junction_log import JunctionLog
from agentic_mpc.run.metrics import MetricsRecorder, ObstacleTrack, obstacle_rows, summarise
from agentic_mpc.run.signal_log import SignalLog
from agentic_mpc.run.stuck import StuckTracker
from agentic_mpc.world.base import World
from agentic_mpc.world.collisions import CollisionEpisode, ReportWithoutContact
from agentic_mpc.world.observation import Observation


@dataclass(frozen=True, slots=True)
class StepOutcome:
    """One control step as the loop saw it: the state and observation at t, what the controller did."""

    observation: Observation
    """At t, before the step."""
    state: Any
    """The plant's [x, y, phi, v] at t."""
    output: Any
    """The controller's :class:`~agentic_mpc.controller.mppi.StepOutput`."""
    specification: Specification
    version: int
    discs: int
    step_ms: float
    """Wall time of the whole step (surroundings, controller, the world's advance)."""


class RunRecorder:
    """Collects a run's rows while it goes and writes its files at the end (also after a failure)."""

    def __init__(self, world: World, traffic_stride: int = 5) -> None:
        self.world = world
        self.traffic_stride = traffic_stride
        self.trajectory_rows: list[dict[str, Any]] = []
        self.traffic_rows: list[dict[str, Any]] = []
        self.specification_events: list[dict[str, Any]] = []
        self.setup_events: list[dict[str, Any]] = []
        start = getattr(world, "ego_start", None)  # SUMO: where the ego really got in (a free gap if it had to)
        if start:
            self.setup_events.append({"event": "ego_inserted", "sim_time_s": start.get("inserted_at_s"), "tau": None,
                                      "source": "world", "result": json.dumps(start, default=str)})
        self.received_calls: list[dict[str, Any]] = []
        self.tactic_events: list[dict[str, Any]] = []
        """``tactic_started`` / ``tactic_ended`` rows (the tactics layer's ``changes``)."""
        self.plan_rows: list[tuple[float, int, float, float]] = []
        self.metrics = MetricsRecorder(stuck=StuckTracker(lane_count=len(world.lanes().lanes)),
                                       junctions=JunctionLog(getattr(world, "ego_length_m", 5.0)))
        self.signals = SignalLog(world.lanes)
        circles = world.obstacle_circles()
        for obstacle in world.observation.obstacles:
            own = tuple(c for c in circles if c.label == obstacle.id)
            track = ObstacleTrack(obstacle.id, own, obstacle.road_s_m, obstacle.lane_index)
            if obstacle.road_s_m < world.observation.ego.road_s_m:
                track.side = "behind at start"  # never in the ego's way: not a blockage it had to pass
            self.metrics.obstacles.append(track)

    def specification_changed(self, specification: Specification, version: int) -> None:
        self.specification_events.append(
            {"event": "specification", "sim_time_s": round(self.world.time_s, 3), "tau": None,
             "result": json.dumps({"version": version, "attached": specification.summary()})}
        )

    def tool_call_received(self, call: dict[str, Any]) -> None:
        """One tool call the MCP server received (any thread), stamped with the world's sim time now."""
        who = "; ".join(
            part for part in (call.get("client") or "unknown client",
                              f"session={call['session']}" if call.get("session") else "",
                              f"address={call['address']}" if call.get("address") else "") if part
        )
        self.received_calls.append(
            {"event": "tool_call_received", "sim_time_s": round(self.world.time_s, 3), "tau": None,
             "source": "mcp", "tool": call.get("tool"), "arguments": call.get("arguments"), "ok": call.get("ok"),
             "result": call.get("result"), "error": call.get("error"), "apply_at_s": call.get("apply_at_s"),
             "client": who}
        )

    def step(self, outcome: StepOutcome, after: Observation) -> None:
        """Record one step: ``outcome`` at t and the observation ``after`` it (t + dt)."""
        before, state, out = outcome.observation, outcome.state, outcome.output
        ego = before.ego
        x, y = float(state[0]), float(state[1])
        row: dict[str, Any] = {
            "time_s": before.time_s, "x_m": x, "y_m": y, "phi_rad": float(state[2]), "v_mps": float(state[3]),
            "delta": out.delta, "throttle": out.throttle, "brake": out.brake,
            "sumo_x_m": ego.x_m, "sumo_y_m": ego.y_m, "sumo_heading_rad": ego.heading_rad,
            "sumo_speed_mps": ego.speed_mps, "lane_id": ego.lane_id, "lane_index": ego.lane_index,
            "lane_role": ego.lane_role, "road_s_m": ego.road_s_m, "lateral_offset_m": ego.lateral_offset_m,
            "spec_version": outcome.version, "spec_summary": outcome.specification.summary(),
            "cost_min": out.cost_min, "effective_samples": out.effective_samples,
            "effective_fraction": out.effective_fraction, "temperature": out.temperature, "solve_ms": out.solve_ms,
            "step_ms": outcome.step_ms, "vehicles_in_range": len(before.traffic), "discs": outcome.discs,
            "collisions": sum(1 for c in before.collisions if c.ego_contact),
            "gap_ahead_m": min((v.gap_m for v in before.traffic if v.relative_lane == 0 and v.relation == "ahead"),
                               default=float("nan")),
        }
        tracking = outcome.specification.get("path_tracking")
        if isinstance(tracking, PathTracking):
            row["tracked_lane"] = tracking.lane
            row["v_ref_mps"] = tracking.v_ref_mps
            row["tracked_lane_offset_m"] = float(tracking.path.lateral_offset(x, y)[0])
        else:
            row["tracked_lane"], row["v_ref_mps"], row["tracked_lane_offset_m"] = "", float("nan"), float("nan")
        self.trajectory_rows.append(row)
        self.metrics.observe(after, self.world.lateral_offset_m, row["v_ref_mps"])
        self.signals.observe(after)
        for emergency in after.emergency_vehicles:
            loss = self.world.time_loss_s(emergency.vehicle.id)
            if loss is not None:
                self.metrics.record_time_loss(emergency.vehicle.id, loss)
        if (len(self.trajectory_rows) - 1) % self.traffic_stride == 0:
            self._traffic(after)

    def plan(self, time_s: float, states: Any) -> None:
        """The controller's optimal predicted trajectory at ``time_s`` ((H, 4) states, k = 1..H)."""
        self.plan_rows.extend(
            (time_s, k, round(float(x), 3), round(float(y), 3)) for k, (x, y) in enumerate(states[:, :2], start=1)
        )

    def _traffic(self, observation: Observation) -> None:
        emergency_ids = {e.vehicle.id for e in observation.emergency_vehicles}
        others = {v.id: v for v in observation.traffic}
        others.update({e.vehicle.id: e.vehicle for e in observation.emergency_vehicles})
        for vehicle in others.values():
            self.traffic_rows.append(
                {
                    "time_s": observation.time_s, "id": vehicle.id, "type_id": vehicle.type_id,
                    "vclass": vehicle.vclass, "x_m": vehicle.x_m, "y_m": vehicle.y_m,
                    "heading_rad": vehicle.heading_rad, "speed_mps": vehicle.speed_mps,
                    "lane_id": vehicle.lane_id, "road_s_m": vehicle.road_s_m, "gap_m": vehicle.gap_m,
                    "relation": vehicle.relation, "emergency": vehicle.id in emergency_ids,
                }
            )

    def write(self, out_dir: Path, identity: dict[str, Any], transcript: list[dict[str, Any]], wall_s: float,
              error: BaseException | None) -> dict[str, Any]:
        """Write the run's CSV files; returns the summary row (``identity`` first, then the metrics)."""
        import pandas as pd

        trajectory = add_motion_columns(pd.DataFrame(self.trajectory_rows))
        trajectory.to_csv(out_dir / files.TRAJECTORY, index=False)
        traffic = pd.DataFrame(self.traffic_rows, columns=list(files.TRAFFIC_COLUMNS))
        traffic.to_csv(out_dir / files.TRAFFIC, index=False)
        if self.plan_rows:
            pd.DataFrame(self.plan_rows, columns=list(files.PLAN_COLUMNS)).to_csv(out_dir / files.PLAN, index=False)
        if self.signals.rows:
            pd.DataFrame(self.signals.rows, columns=list(files.SIGNAL_COLUMNS)).to_csv(out_dir / files.SIGNALS,
                                                                                        index=False)
        self.metrics.stuck.finish()
        collisions = [collision_event(e) for e in self.metrics.collisions.episodes] + self.metrics.stuck.events()
        collisions += [report_without_contact_event(r) for r in self.metrics.collisions.reports_without_contact]
        events = events_table(sorted(self.setup_events + transcript + list(self.received_calls)
                                     + self.specification_events + self.tactic_events + collisions
                                     + self.metrics.junctions.events,
                                     key=lambda r: (r.get("sim_time_s") is None, r.get("sim_time_s") or 0.0)))
        events.to_csv(out_dir / files.EVENTS, index=False)
        summary: dict[str, Any] = {
            **identity,
            "status": "ok" if error is None else "failed",
            "error": "" if error is None else f"{type(error).__name__}: {error}",
        }
        summary.update(
            summarise(trajectory, self.metrics, goal_s_m=self.world.goal_s_m,
                      agent_tool_calls=int((events["event"] == "tool_call").sum()) if len(events) else 0)
        )
        summary.update(comfort_summary(trajectory, [track.road_s_m for track in self.metrics.obstacles]))
        rescue = getattr(self.world, "rescue_lanes", None)  # SUMO worlds: whether SUMO's drivers formed them
        summary["rescue_lanes"] = "" if rescue is None else bool(rescue)
        summary["wall_s"] = round(wall_s, 3)
        pd.DataFrame([summary]).to_csv(out_dir / files.SUMMARY, index=False)
        pd.DataFrame(
            [(c.label, c.x_m, c.y_m, c.radius_m) for track in self.metrics.obstacles for c in track.circles],
            columns=list(files.OBSTACLE_COLUMNS),
        ).to_csv(out_dir / files.OBSTACLES, index=False)
        pd.DataFrame(obstacle_rows(self.metrics), columns=list(files.OBSTACLE_PASS_COLUMNS)).to_csv(
            out_dir / files.OBSTACLE_PASSES, index=False)
        return summary


def collision_event(episode: CollisionEpisode) -> dict[str, Any]:
    """The ``events.csv`` row of one collision episode."""
    fault = "ego at fault" if episode.ego_at_fault else "ego not at fault"
    return {
        "event": "collision", "sim_time_s": round(episode.time_s, 3), "tau": None, "source": episode.source,
        "content": f"{episode.cause}: ego and {episode.other_id} ({fault})",
        "result": {"other": episode.other_id, "other_type": episode.other_type, "cause": episode.cause,
                   "ego_at_fault": episode.ego_at_fault, "ego_speed_mps": round(episode.ego_speed_mps, 3),
                   "other_speed_mps": round(episode.other_speed_mps, 3)},
    }


def report_without_contact_event(report: ReportWithoutContact) -> dict[str, Any]:
    """The ``events.csv`` row of a collision SUMO reported that the footprints do not confirm (not counted)."""
    return {
        "event": "sumo_collision_report", "sim_time_s": round(report.time_s, 3), "tau": None, "source": "sumo",
        "content": f"SUMO reported a collision of the ego and {report.other_id}; the footprints stayed "
                   f"{report.min_gap_m:.2f} m apart or more: not counted as a collision",
        "result": {"other": report.other_id, "other_type": report.other_type,
                   "min_footprint_gap_m": round(report.min_gap_m, 3)},
    }


def events_table(transcript: list[dict[str, Any]]) -> Any:
    """The transcript as one row per message, tool call and result, with tau and simulation time."""
    import pandas as pd

    rows = []
    for record in transcript:
        row = {key: record.get(key) for key in files.EVENT_COLUMNS}
        for key in ("arguments", "result"):
            if row[key] is not None and not isinstance(row[key], str):
                row[key] = json.dumps(row[key], default=str)
        rows.append(row)
    return pd.DataFrame(rows, columns=list(files.EVENT_COLUMNS))
