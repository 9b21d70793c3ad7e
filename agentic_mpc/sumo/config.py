"""What a SUMO world is made of: the network, route files, the ego's start, scenario vehicles and obstacles.

Validated (pydantic) before SUMO starts; positions name a lane of the ego's road by index or role. The
controller's and the specification's settings are not here: they belong to the run (see the scenario).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from agentic_mpc.frozen_config import FrozenConfig

LaneRef = int | Literal["left", "center", "right"]


class SurroundingsConfig(FrozenConfig):
    """How the observation becomes the controller's surroundings."""


    clearance_margin_m: float = Field(
        0.5, ge=0, description="disc radius = (W + W_ego)/2 + margin; also how far the cover overshoots at corners"
    )
    heading_aware_covers: bool = Field(
        True, description="a cover grows by how much further the ego's corner reaches when it is turned against the "
        "vehicle (about its half length x |sin| of the angle); False: the covers assume the ego aligned"
    )
    max_discs_per_vehicle: int = Field(8, ge=1, le=16)
    lane_entry_margin_m: float | None = Field(
        0.4, ge=0, description="cover at least half the lane width + this sideways (None: physical size only)"
    )
    range_ahead_m: float = Field(80.0, gt=0, description="vehicles further ahead (along the road) are left out")
    range_behind_m: float = Field(40.0, ge=0, description="vehicles further behind are left out")
    longitudinal_slack_m: float = Field(
        12.0, ge=0, description="a vehicle is relevant if it comes this close (beyond its cover) within the horizon"
    )
    ignore_followers_in_lane: bool = Field(True, description="leave out vehicles right behind in the ego's lane")
    leader_time_headway_s: float = Field(
        0.0, ge=0, description="the cover of a vehicle ahead in the ego's lane reaches back this headway (off by "
        "default: J0's time-gap term keeps the distance by braking; this cover made the ego swerve after cut-ins)"
    )
    leader_standstill_gap_m: float = Field(2.0, ge=0, description="... plus this gap (the ego keeps its distance)")
    passing_lanes_within_m: float | None = Field(
        80.0,
        ge=0,
        description="a static obstacle this close ahead in the ego's lane opens the lanes beside it: they join the "
        "corridor and their traffic gets the lane-entry cover, so the ego may go round it there and merges as into "
        "any lane it enters (None: only the lane J1 tracks)",
    )
    follower_yield_mps2: float = Field(
        2.0,
        ge=0,
        le=9.0,
        description="a follower in a lane beside a blockage is predicted to brake this hard to let the ego in (gap "
        "acceptance for the zipper; 0: it keeps its speed)",
    )
    follower_yield_merge_accel_mps2: float | None = Field(
        2.0,
        ge=0,
        description="a follower is predicted to brake to let the ego in only if it can, braking at follower_yield_mps2 "
        "while the ego speeds up at this rate (else it keeps its speed: 3612 pulled out at 1 m/s in front of a car at "
        "14 m/s 16 m back, and side-swiped it); None: every follower beside a blockage is predicted to yield",
    )
    detour_beside_queues: bool = Field(
        True,
        description="once the ego's centre is in the lane beside a queue that blocks the lane J1 tracks (or beside a "
        "lone stopped obstacle 20 m ahead or more), or it stands in that lane behind a lone stopped obstacle partly "
        "aside, J1 follows the lane beside (on that side) until "
        "the ego is past the obstacle (pulled back towards the queue, the ego stood wedged beside it, or in line "
        "behind it: docs/traffic.md)",
    )
    detour_ahead_of_queues_m: float | None = Field(
        80.0,
        gt=0,
        description="a queue with cars in it this close ahead in the lane J1 tracks, the ego driving in that lane: J1 "
        "follows the lane beside on J3's preferred side (the other side if the road has no lane there) until the ego "
        "is past, so that it merges while it moves, as SUMO's drivers change lanes ahead of a blockage, rather than "
        "braking late from 15 m/s and swerving or standing nose to tail; not while an emergency vehicle is this close "
        "(docs/traffic.md; None: off)",
    )
    detour_merge_waits_from_mps: float | None = Field(
        None,
        gt=0,
        description="with the detour ahead of a queue, while the ego is at least this fast and its centre still in "
        "the tracked lane, J1 follows the lane beside only when that lane has room beside the ego "
        "(sumo.queues.room_to_merge), else the tracked lane with its reference slowed to stop with room behind the "
        "queue. None (the default): off; at 8.0 it ended the merges pressed to a car alongside (4459) but on unseen "
        "4640-4679 it stopped a run behind the stopped car for 91 s (docs/traffic.md)",
    )
    approach_decel_mps2: float | None = Field(
        None,
        gt=0,
        description="coming up to a queue (cars standing behind a stopped one) in the lane the ego is in, J1's "
        "reference slows so that braking at this rate stops it with room to pull out (None, the default: at v_ref "
        "until J0 sees the queue 2 s ahead; the ego then braked at 5 m/s^2 and stood 1.6 m behind the queue's last "
        "car). Off: at 2.0 it was mixed on seen seeds 900-919 and worse on unseen 2100-2119 (docs/traffic.md)",
    )
    edges: Literal["road", "corridor", "none"] = Field(
        "road",
        description="the edges J0 keeps the ego between: the road's; the corridor of the lanes the ego may use"
        " (those its box overlaps + the lane J1 tracks); or none",
    )
    lane_lines: bool = Field(
        True,
        description="J0 sees the lines between lanes: a plan that ends standing across one pays (false: only "
        "other road users and the edges keep a standing ego anywhere)",
    )
    lane_neighbours: bool = Field(
        False, description="J0 gets the vehicles in the lanes beside the ego's that it may enter, for its lane-entry "
        "gap (with Mandatory.lane_entry_gap_weight > 0; off by default: docs/traffic.md, 'Gap acceptance when "
        "entering a lane')",
    )
    followers_charge_approach: bool = Field(
        False,
        description="while the ego stands, the discs of a vehicle closing in from behind in a lane beside charge a "
        "plan only as far as it comes closer to that vehicle's line (false, the default: wherever it is inside them; "
        "on, a car standing partly in a truck's lane no longer raced it, but a car waiting to merge stood longer: "
        "docs/traffic.md, 'A follower passing a standing car')",
    )


class EgoStart(FrozenConfig):
    """Where the ego enters. Positions are SUMO lane positions of the FRONT bumper, as in SUMO's departPos."""

    edge_id: str | None = Field(None, description="edge of the road to start on (default: the road's first)")
    lane: LaneRef = Field("center", description="lane index or role")
    pos_m: float = Field(30.0, ge=0, description="front-bumper lane position")
    speed_mps: float = Field(15.0, ge=0, le=60)
    lateral_offset_m: float = Field(0.0, description="start this far left (+) of the lane centre")
    match_leader_within_m: float | None = Field(
        None, gt=0,
        description="as the ego enters (after any warm-up): a vehicle ahead in its lane within this bumper gap sets"
        " its speed (never above speed_mps), lowered until SUMO accepts the gap (LaMPilot's evaluator)",
    )


class _Placed(FrozenConfig):
    """A vehicle the scenario puts on a lane of the road: which, of what type, where."""

    id: str = Field(..., min_length=1)
    type_id: str
    edge_id: str | None = Field(None, description="edge of the road (default: the road's first)")
    lane: LaneRef = "center"
    pos_m: float = Field(..., ge=0, description="front-bumper lane position")


class VehicleSpawn(_Placed):
    """A SUMO-driven vehicle placed by the scenario (in addition to any traffic in the route files)."""

    type_id: str = "car"
    speed_mps: float = Field(0.0, ge=0)
    depart_s: float | None = Field(None, ge=0, description="insertion time (None: at the start)")
    max_speed_mps: float | None = Field(None, gt=0)
    speed_factor: float | None = Field(None, gt=0)
    imperfection: float | None = Field(None, ge=0, le=1, description="Krauss sigma (0 = perfect driver)")
    lane_changes: bool = Field(True, description="False: SUMO never changes this vehicle's lane")


class StaticObstacle(_Placed):
    """A stopped vehicle on a lane: SUMO traffic drives around or stops behind it, and J2 sees it."""

    type_id: str = "obstacle"
    in_j2: bool = Field(True, description="add it to the initial specification's obstacle avoidance (J2)")


BLUELIGHT_PARAM_KEYS = (
    "device.bluelight.reaction-prob-far",
    "device.bluelight.reaction-prob-near",
    "device.bluelight.near-dist",
    "device.bluelight.reactiondist",
    "device.bluelight.mingapfactor",
)
"""The vType/vehicle parameters SUMO 1.28's bluelight device reads (MSDevice_Bluelight.cpp): the reaction
probabilities (per second) and near-dist every step, reactiondist and mingapfactor when the device is built."""


class RescueLanes(FrozenConfig):
    """SUMO's drivers form a rescue lane for emergency vehicles (the bluelight device under the sublane model).

    Measured on the curved 3-lane road (docs/traffic.md): 3 cars abreast ahead of an ambulance cost it 38 s
    without this, about 1 s with it. Needs the sublane model (switched on at ``lateral_resolution_m`` of the
    simulation; 0.8 m is too coarse for a 2.2 m ambulance to fit) and lanes wide enough (3.5 m and up)."""

    enabled: bool | None = Field(
        None, description="None: on when the scenario has emergency vehicles (route files or spawns), else off"
    )
    reaction_dist_m: float = Field(
        100.0, gt=0, description="--device.bluelight.reactiondist (SUMO's 25 m is too short at 25 m/s)"
    )
    emergency_params: dict[str, float] = Field(
        default_factory=lambda: {"device.bluelight.reaction-prob-far": 1.0, "device.bluelight.reaction-prob-near": 1.0},
        description="parameters set on every emergency vType (SUMO's defaults: 0.189 and 0.577 per second)",
    )
    release_behind_m: float | None = Field(
        None, gt=0,
        description="drivers an emergency vehicle is this far past change lanes again (None: reaction_dist_m). SUMO"
        " 1.28 allows them no strategic or speed-gain lane changes while it is on their edge, so on a long edge a"
        " queue behind a stopped car never merged past it (docs/traffic.md)",
    )

    release_blocked_within_m: float | None = Field(
        15.0, gt=0,
        description="drivers standing with a stopped obstacle ahead this close change lanes again while their "
        "emergency vehicle stands too (None: only once it has passed them): it cannot pass them, and SUMO's queue "
        "waited for it for good",
    )

    @field_validator("emergency_params")
    @classmethod
    def _known_keys(cls, params: dict[str, float]) -> dict[str, float]:
        unknown = sorted(set(params) - set(BLUELIGHT_PARAM_KEYS))
        if unknown:
            raise ValueError(f"unknown bluelight parameters {unknown}; SUMO knows {list(BLUELIGHT_PARAM_KEYS)}")
        negative = sorted(k for k, v in params.items() if v < 0)
        if negative:
            raise ValueError(f"bluelight parameters must not be negative: {negative}")
        if params.get("device.bluelight.mingapfactor", 1.0) != 1.0:
            # SUMO applies it to the whole vType's collision minGap factor, for good (MSDevice_Bluelight.cpp)
            raise ValueError("device.bluelight.mingapfactor must stay 1: other values change the vType permanently")
        return params


class SumoConfig(FrozenConfig):
    """The SUMO world of a run: network, traffic, the ego's start, obstacles; validated before SUMO starts.

    The seed is the run's (given to :class:`~agentic_mpc.sumo.world.SumoWorld`), not a field here."""

    net_file: Path
    route_files: tuple[Path, ...] = Field(..., min_length=1, description="must define the vTypes used")
    road: str | tuple[str, ...] = Field(
        ..., description="the ego's road: a start edge (followed while it has one successor) or the edge list"
    )
    sublane: bool = Field(
        False, description="SUMO's sublane model (lateral behaviour, about 10x per step); rescue lanes switch it on"
    )
    lateral_resolution_m: float = Field(0.4, gt=0, description="sublane width; at most the narrowest lane's width")
    rescue_lanes: RescueLanes = RescueLanes()
    ego: EgoStart = EgoStart()
    ego_id: str = "ego"
    ego_type_id: str = "ego"
    vehicles: tuple[VehicleSpawn, ...] = ()
    obstacles: tuple[StaticObstacle, ...] = ()
    warmup_s: float = Field(0.0, ge=0, description="SUMO runs alone this long before the ego enters")
    ego_insert_wait_s: float = Field(
        2.0, gt=0, le=60,
        description="how long SUMO may take to insert the ego at its spot before the free gaps of its lane nearest"
        " to it are tried (each for 0.5 s); where it entered is the world's ego_start",
    )
    goal_s_m: float | None = Field(
        None, description="along-road position of the ego's goal (default: 40 m before the road's end)"
    )
    sensing_range_m: float = Field(150.0, gt=0)
    keep_route: Literal[2, 3] = Field(3, description="moveToXY keepRoute for the ego (see SumoBridge)")
    surroundings: SurroundingsConfig = SurroundingsConfig()
    edge_out_min_gap_m: float | None = Field(
        None, gt=0,
        description="SUMO's drivers standing at their minGap behind a stopped obstacle for edge_out_after_s get this"
        " minGap (0.5 m resolves the deadlock of incident_in_traffic seed 913) so that its lane-change model lets"
        " them edge out; None (the default: not better on seeds 1000-1019, docs/traffic.md): SUMO's own minGap",
    )
    edge_out_after_s: int = Field(10, ge=1, le=600, description="see edge_out_min_gap_m (whole seconds)")
    centre_lateral_offsets: bool = Field(
        True,
        description="observe SUMO drivers' lateral offsets at their centres, where J0's discs then sit; False: SUMO's"
        " lateral position, the front's (0.8 m off the centre of a 12 m truck turned while changing lanes, and the"
        " discs as far off its body: docs/traffic.md)",
    )
    straighten_wedged_after_s: float | None = Field(
        5.0, gt=0, le=600,
        description="SUMO's drivers standing this long astride a lane line, wedged by a stopped obstacle in the lane"
        " beside, are moved back to their lane's centre (a truck so wedged held the ego behind it for 80 s:"
        " docs/traffic.md); None: left to SUMO",
    )
    ego_standing_min_gap_m: float | None = Field(
        None, ge=0, le=10,
        description="with stopped-car obstacles, the ego's minGap in SUMO while it stands (< 0.5 m/s): SUMO's sublane"
        " model blocks every sideways move of a car the ego stands closer behind than its minGap (incident_in_traffic"
        " 4415: the road stood for good; docs/traffic.md); None: the ego's vType minGap always",
    )
    announce_lane_changes: bool = Field(
        True,
        description="SUMO's drivers told of the ego's lane changes (its plan): followers in the lane it enters asked"
        " to open a gap, braking at most surroundings.follower_yield_mps2 (agentic_mpc.sumo.intention)",
    )
    show_ego_outline: bool = Field(
        True,
        description="under the sublane model, the part of the ego that sticks into the next lane is a vehicle of"
        " that size in SUMO, so that its drivers there react to it (agentic_mpc.sumo.outline); False: SUMO sees the"
        " ego only in the lane its centre is in",
    )
    sumo_log_file: Path | None = None
    quiet: bool = Field(True, description="suppress SUMO's warnings on stderr")

    def replace(self, **changes: Any) -> SumoConfig:
        """A validated copy with ``changes`` (pydantic's ``model_copy(update=...)`` skips validation)."""
        return type(self).model_validate({**dict(self), **changes})

    @field_validator("route_files", mode="before")
    @classmethod
    def _one_or_many(cls, value: Any) -> Any:
        return (value,) if isinstance(value, (str, Path)) else value

    @model_validator(mode="after")
    def _unique_ids(self) -> SumoConfig:
        ids = [self.ego_id, *(v.id for v in self.vehicles), *(o.id for o in self.obstacles)]
        duplicates = sorted({i for i in ids if ids.count(i) > 1})
        if duplicates:
            raise ValueError(f"vehicle ids must be unique, duplicated: {duplicates}")
        return self
