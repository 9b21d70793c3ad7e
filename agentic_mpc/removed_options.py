"""Every option a configuration model no longer takes, in one place: a scenario that still names one fails
``agentic-mpc check`` saying what became of it (``FrozenConfig.removed_fields``). The options that shipped off and
were removed on 2026-12-06 were each measured worse or no better on unseen seeds; their measurements are in
docs/history.md (``REMOVED_SWITCHES_DOC``)."""

from __future__ import annotations

REMOVED_SWITCHES_DOC = "docs/history.md#switches-removed-on-2026-12-06"


def removed_switch(why: str) -> str:
    """The message for an option that shipped off and was removed: why, and where its measurements are."""
    return f"{why} (it shipped off; its measurements: {REMOVED_SWITCHES_DOC})"


def now_a_tactic(where: str) -> str:
    return f"it is now tactics: {{{where}}} (agentic_mpc/tactics/config.py)"


SURROUNDINGS = {  # simulation.surroundings
    "passing_lanes_within_m": now_a_tactic("passing_lanes: {within_m: ...}"),
    "follower_yield_mps2": now_a_tactic("gap_acceptance: {follower_yield_mps2: ...}"),
    "follower_yield_merge_accel_mps2": now_a_tactic("gap_acceptance: {merge_accel_mps2: ...}"),
    "detour_beside_queues": now_a_tactic("rules: [...] without pass_beside_queue and pull_out_past_stopped_car"),
    "detour_ahead_of_queues_m": now_a_tactic("merge_ahead_of_queue: {within_m: ...}"),
    "leader_time_headway_s": removed_switch("J0's time gap keeps the distance; this cover made the ego swerve"),
    "approach_decel_mps2": removed_switch("slowing J1 towards a queue was mixed on seen seeds, worse on unseen ones"),
    "detour_merge_waits_from_mps": removed_switch("waiting for room before the merge stood a run 91 s on unseen seeds"),
    "lane_neighbours": removed_switch("J0's lane-entry gap was worse on unseen seeds"),
    "followers_charge_approach": removed_switch("a car waiting to merge stood longer"),
}
SIMULATION = {  # simulation
    "edge_out_min_gap_m": removed_switch("a small minGap for drivers behind a stopped car was not better"),
    "edge_out_after_s": removed_switch("it went with edge_out_min_gap_m"),
    "ego_standing_min_gap_m": removed_switch("a small minGap for the standing ego traded misses for runs at fault"),
}
CONTROLLER = {"standstill_winner": removed_switch("starting from the best sample at a standstill was no better")}
MANDATORY = {key: removed_switch("J0's lane-entry gap was worse on unseen seeds")  # specification.mandatory
             for key in ("lane_entry_gap_weight", "lane_entry_time_gap_s")}
