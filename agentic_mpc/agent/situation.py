"""What the agent knows of the moment, read through MCP resources as any MCP host would.

- :func:`read_situation` reads ``sumo://ego``, ``sumo://emergency-vehicles`` and ``mpc://specification`` at the
  start of an agent step; :func:`describe_situation` turns them into a few lines that go with the user message
  (``Message.context``) to a language model. The rule-based backend reads only the message itself.
- :class:`EmergencyWatch` reads the run's emergency-vehicle events (an ambulance coming up behind, its
  passing: decided once, by the run's detector, :mod:`agentic_mpc.world.emergency`) from
  ``sumo://emergency-vehicles``; the agent wakes itself on each new one, in-process or across a process
  boundary alike.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from agentic_mpc.agent.connect import read_json_resource
from agentic_mpc.mcp.protocol import (
    EGO_URI,
    EMERGENCY_VEHICLES_URI,
    ROAD_URI,
    SPECIFICATION_URI,
    TACTICS_URI,
    TRAFFIC_URI,
)
from agentic_mpc.world.emergency import EmergencyEvent
from agentic_mpc.world.lanes import LEADER_RANGE_M

MAX_EMERGENCY_LISTED = 3


async def read_situation(client: Any) -> str | None:
    """The current situation as a few lines, or None if the server has none of the resources."""
    ego = await read_json_resource(client, EGO_URI, missing=logging.INFO)
    emergency = await read_json_resource(client, EMERGENCY_VEHICLES_URI, missing=logging.INFO)
    specification = await read_json_resource(client, SPECIFICATION_URI, missing=logging.INFO)
    traffic = await read_json_resource(client, TRAFFIC_URI, missing=logging.INFO)
    road = await read_json_resource(client, ROAD_URI, missing=logging.INFO)
    tactics = await read_json_resource(client, TACTICS_URI, missing=logging.INFO)
    return describe_situation(ego, emergency, specification, traffic, road, tactics)


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None


def describe_situation(ego: dict[str, Any] | None, emergency: dict[str, Any] | None,
                       specification: dict[str, Any] | None, traffic: dict[str, Any] | None = None,
                       road: dict[str, Any] | None = None, tactics: dict[str, Any] | None = None) -> str | None:
    """``Current situation (t = 12.3 s): ...`` from the resources' JSON (any of them may be None)."""
    lines: list[str] = []
    t = _number((ego or {}).get("time_s"))
    car = (ego or {}).get("ego") or {}
    speed = _number(car.get("speed_mps"))
    if speed is not None:
        lane = car.get("lane_role") or "no"
        offset = _number(car.get("lateral_offset_m"))
        where = f" {abs(offset):.1f} m {'left' if offset > 0 else 'right'} of its centre" if offset and abs(offset) >= 0.3 else ""
        lines.append(f"- we drive at {speed:.1f} m/s ({speed * 3.6:.0f} km/h) in the {lane} lane{where}")
    if road is not None and (sides := _sides_line(road, car.get("lane_index"))):
        lines.append(sides)
    if traffic is not None:
        lines.append(_leader_line(traffic))
    if emergency is not None:
        vehicles = [v for v in emergency.get("emergency_vehicles") or [] if isinstance(v, dict)]
        if not vehicles:
            lines.append("- no emergency vehicle around")
        for vehicle in vehicles[:MAX_EMERGENCY_LISTED]:
            distance = _number(vehicle.get("distance_m"))
            kind = vehicle.get("type_id") or vehicle.get("vclass") or "emergency vehicle"
            lane = vehicle.get("lane_role") or "another"
            gap = f"{distance:.0f} m " if distance is not None else ""
            where = {"ahead": "ahead of us (past us: it needs no way from us)",
                     "behind": "behind us"}.get(vehicle.get("relation"), "beside us")
            lines.append(f"- emergency vehicle {kind!s} '{vehicle.get('id')}' {gap}{where}, in the {lane} lane")
    if specification is not None and specification.get("summary"):
        lines.append(f"- attached: {specification['summary']}")
    active = (tactics or {}).get("active")
    if isinstance(active, dict):  # the specification's J1 shaped by a tactic: the agent should know why
        lines.append(f"- tactic {active.get('rule')}: path tracking follows lane {active.get('followed_lane')} "
                     f"instead of lane {active.get('tracked_lane')} to pass {active.get('obstacle_id')}")
    if (tactics or {}).get("junction"):  # a light, a stop sign, a turn's speed: why the car slows
        lines.append(f"- junction rules: {tactics['junction']}")
    if not lines:
        return None
    stamp = f" (t = {t:.1f} s)" if t is not None else ""
    return f"Current situation{stamp}:\n" + "\n".join(lines)


def _sides_line(road: dict[str, Any], lane_index: Any) -> str | None:
    """How many lanes lie to each side of ours (and which is the emergency lane), from ``sumo://road``."""
    lanes = [lane for lane in road.get("lanes") or [] if isinstance(lane, dict)]
    indices = [lane.get("index") for lane in lanes]
    if not isinstance(lane_index, int) or lane_index not in indices:
        return None
    position = indices.index(lane_index)  # listed from the road edge outwards
    edge_side, far_side = ("left", "right") if road.get("lefthand") else ("right", "left")
    toward_edge, away = lanes[:position], lanes[position + 1:]
    text = f"- lanes to our {far_side}: {len(away)}, to our {edge_side}: {len(toward_edge)}"
    if road.get("emergency_lane") in [lane.get("name") for lane in toward_edge]:
        text += f" (the {edge_side}-most of them the emergency lane)"
    return text


def _leader_line(traffic: dict[str, Any]) -> str:
    """The car ahead in our lane (for a following distance or an overtake), from ``sumo://traffic``."""
    ahead = [v for v in traffic.get("vehicles") or [] if isinstance(v, dict) and v.get("relation") == "ahead"
             and v.get("relative_lane") == 0 and _number(v.get("gap_m")) is not None and 0 <= v["gap_m"] <= LEADER_RANGE_M]
    if not ahead:
        return f"- no car ahead in our lane within {LEADER_RANGE_M:g} m"
    leader = min(ahead, key=lambda v: v["gap_m"])
    speed = _number(leader.get("speed_mps"))
    at = f" at {speed:.1f} m/s" if speed is not None else ""
    return f"- car ahead in our lane: '{leader.get('id')}' {leader['gap_m']:.0f} m ahead (bumper to bumper){at}"


class EmergencyWatch:
    """The run's emergency-vehicle events as the agent reads them from ``sumo://emergency-vehicles`` (its
    ``events``, every one so far): each new one once. The run decides them; the agent only relays them."""

    def __init__(self) -> None:
        self.seen: int | None = None
        """How many of the resource's events the agent has had (None: not read yet)."""
        self._warned = False

    async def start(self, client: Any) -> None:
        """Skip what is over before the agent came: every event up to the last "passed" (an emergency vehicle
        approaching now is still said)."""
        events = await self._read(client)
        passed = [i for i, event in enumerate(events or []) if event.kind == "emergency_vehicle_passed"]
        self.seen = passed[-1] + 1 if passed else 0

    async def check(self, client: Any) -> list[EmergencyEvent]:
        """Read the resource once and return the events it lists that are new (none if it cannot be read)."""
        events = await self._read(client)
        if events is None:
            return []
        new = events[self.seen or 0:]
        self.seen = len(events)
        return new

    async def _read(self, client: Any) -> list[EmergencyEvent] | None:
        resource = await read_json_resource(client, EMERGENCY_VEHICLES_URI, missing=logging.INFO)
        if resource is None:
            return None
        items = resource.get("events")
        try:
            if isinstance(items, list):
                return [EmergencyEvent.from_json(item) for item in items]
            problem = "no events listed (a server that does not decide them)"
        except ValueError as error:
            problem = str(error)
        if not self._warned:  # said once: a realtime agent reads it on every update
            self._warned = True
            logging.getLogger(__name__).warning("%s: %s", EMERGENCY_VEHICLES_URI, problem)
        return None

    async def listen(self, client: Any, wake: Callable[[], None]) -> str:
        """Call ``wake`` on every update of the resource the server announces (subscribed over MCP). Returns
        only if the subscription fails: why (the agent still gets messages, it just cannot wake itself)."""
        try:
            async with client.listen(resource_subscriptions=[EMERGENCY_VEHICLES_URI]) as updates:
                async for _ in updates:
                    wake()
        except Exception as error:  # noqa: BLE001 - any failure: say so once
            logging.getLogger(__name__).warning("no updates of %s: %s; the agent will not wake on emergency "
                                                "vehicles", EMERGENCY_VEHICLES_URI, error)
            return str(error) or type(error).__name__
        return "the server ended the subscription"
