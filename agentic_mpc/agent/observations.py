"""Observation messages: the world can wake the agent, not only the passenger.

:class:`EmergencyWatch` reads observations (the ``dict`` of ``Observation.to_json()``) and produces a
message when an emergency vehicle comes up behind the ego within ``distance_m``, and another when every
such vehicle has passed (is ``passed_margin_m`` ahead) or left the observation.

Keys read: ``time_s``; ``ego.x_m``, ``ego.y_m`` and the ego heading ``ego.heading_rad`` (or ``phi_rad`` /
``yaw_rad``; 0 = +x, counter-clockwise); for each of ``emergency_vehicles``: ``id`` and either the SUMO
bridge's along-road ``relation`` ("behind" / "ahead" / "alongside") with ``distance_m`` (and
``relative_lane``, None off the ego's road), or else ``x_m``, ``y_m`` (measured along the ego's heading);
optionally ``type`` / ``type_id`` / ``vclass`` for the wording and ``speed_mps``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from pydantic import BaseModel, ConfigDict, Field


class EmergencyWatchConfig(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    distance_m: float = Field(80.0, gt=0, description="wake when an emergency vehicle is this close behind")
    passed_margin_m: float = Field(10.0, ge=0, description="it has passed once this far ahead of the ego (centres)")
    lateral_window_m: float = Field(12.0, gt=0, description="ignore vehicles further to the side (other roads)")
    gone_after_s: float = Field(2.0, ge=0, description="an announced vehicle missing this long has gone")


def _heading(ego: dict[str, Any]) -> float:
    for key in ("heading_rad", "phi_rad", "yaw_rad"):
        if isinstance(ego.get(key), int | float):
            return float(ego[key])
    return 0.0


def _xy(vehicle: dict[str, Any]) -> tuple[float, float] | None:
    x, y = vehicle.get("x_m"), vehicle.get("y_m")
    if isinstance(x, int | float) and isinstance(y, int | float) and math.isfinite(x) and math.isfinite(y):
        return float(x), float(y)
    return None


def _label(vehicle: dict[str, Any]) -> str:
    kind = next((str(vehicle[k]) for k in ("type", "type_id", "vclass") if vehicle.get(k)), "")
    return f"{kind} '{vehicle.get('id')}'" if kind else f"'{vehicle.get('id')}'"


def _along_road(vehicle: dict[str, Any]) -> float | None:
    """Signed distance along the road (positive ahead) from the bridge's relation, if it gives one."""
    relation, distance = vehicle.get("relation"), vehicle.get("distance_m")
    if relation not in ("behind", "ahead", "alongside") or not isinstance(distance, int | float):
        return None
    return {"behind": -1.0, "ahead": 1.0, "alongside": 0.0}[relation] * abs(float(distance))


@dataclass
class EmergencyWatch:
    config: EmergencyWatchConfig = field(default_factory=EmergencyWatchConfig)
    _announced: dict[str, dict[str, Any]] = field(default_factory=dict)
    _missing_since: dict[str, float] = field(default_factory=dict)

    def update(self, observation: dict[str, Any]) -> list[str]:
        """The messages this observation warrants (usually none)."""
        ego = observation.get("ego") or {}
        ego_xy = _xy(ego)
        if ego_xy is None:
            return []
        t = observation.get("time_s")
        stamp = f"Observation (t = {t:.1f} s): " if isinstance(t, int | float) else "Observation: "
        seen: dict[str, tuple[float, float, dict[str, Any]]] = {}
        for vehicle in observation.get("emergency_vehicles") or []:
            if not isinstance(vehicle, dict) or vehicle.get("id") is None:
                continue
            along_road = _along_road(vehicle)
            if along_road is not None:
                if "relative_lane" in vehicle and vehicle["relative_lane"] is None:
                    continue  # not on the ego's road
                # The bridge's distance is bumper to bumper: "ahead" at any distance has cleared the ego.
                logic = along_road + self.config.passed_margin_m if along_road > 0 else along_road
                seen[str(vehicle["id"])] = (logic, along_road, vehicle)
                continue
            xy = _xy(vehicle)
            if xy is None:
                continue
            # Measured along the emergency vehicle's heading (it follows the road; the ego may be mid lane
            # change), or the ego's when it has none.
            has_heading = any(k in vehicle for k in ("heading_rad", "phi_rad", "yaw_rad"))
            heading = _heading(vehicle) if has_heading else _heading(ego)
            forward = (math.cos(heading), math.sin(heading))
            dx, dy = xy[0] - ego_xy[0], xy[1] - ego_xy[1]
            along = dx * forward[0] + dy * forward[1]
            across = -dx * forward[1] + dy * forward[0]
            if abs(across) <= self.config.lateral_window_m:
                seen[str(vehicle["id"])] = (along, along, vehicle)

        messages = []
        new = [
            (vid, along, vehicle)
            for vid, (along, _, vehicle) in seen.items()
            if vid not in self._announced and -self.config.distance_m <= along < 0.0
        ]
        now = float(t) if isinstance(t, int | float) else 0.0
        for vid, along, vehicle in new:
            self._announced[vid] = vehicle
            messages.append(
                f"{stamp}An emergency vehicle ({_label(vehicle)}) is approaching from behind, {-along:.0f} m back."
            )
        for vid in self._announced:
            if vid in seen:
                self._missing_since.pop(vid, None)
            else:
                self._missing_since.setdefault(vid, now)
        if self._announced and not new:
            waiting = [
                vid
                for vid in self._announced
                if (vid in seen and seen[vid][0] <= self.config.passed_margin_m)
                or (vid not in seen and now - self._missing_since[vid] < self.config.gone_after_s)
            ]
            if not waiting:
                passed = ", ".join(_label(v) for v in self._announced.values())
                ahead = [seen[vid][1] for vid in self._announced if vid in seen]
                where = f"; it is now {min(ahead):.0f} m ahead" if ahead else "; it is out of sight"
                messages.append(f"{stamp}The emergency vehicle ({passed}) has passed us{where}.")
                self._announced.clear()
                self._missing_since.clear()
        return messages
