"""Choosing the way: what a world with junctions offers the agent's tools (``turn_at_next_junction``,
``drive_to``) and the ``sumo://route`` resource. The tools know this protocol, not the simulator; the SUMO world
implements it (:class:`~agentic_mpc.sumo.route_planner.SumoRoutePlanner`).

A new route is planned where the tool is called (refused with the reason if the junction does not offer that
way) and driven from the world's next step: the world swaps its road between two steps, and J1 follows the new
route's path (:meth:`RoutePlanner.follow` returns it)."""

from __future__ import annotations

from typing import Any, Protocol

from agentic_mpc.geometry import LanePath


class RouteRefused(ValueError):
    """A way the network does not offer from here (the message says what it offers)."""


class RoutePlanner(Protocol):
    def describe(self) -> dict[str, Any]:
        """The route and the next junction where the road divides: distance, the directions it offers, the light."""

    def plan_turn(self, direction: str) -> Any:
        """A plan to take the next junction in ``direction`` ("left", "right", "straight"), or :class:`RouteRefused`."""

    def plan_destination(self, edge_id: str) -> Any:
        """A plan to drive to ``edge_id``, or :class:`RouteRefused`."""

    def follow(self, plan: Any) -> LanePath:
        """Drive ``plan`` from the world's next step; returns the path J1 follows on it."""
