"""What a SUMO world is made of: the network, route files, the ego's start, scenario vehicles and obstacles.

Validated (pydantic) before SUMO starts; positions name a lane of the ego's road by index or role. The
controller's and the specification's settings are not here: they belong to the run (see the scenario).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar, Literal

from pydantic import ConfigDict, Field, field_validator, model_validator

from agentic_mpc import removed_options
from agentic_mpc.frozen_config import FrozenConfig

LaneRef = int | Literal["left", "center", "right"]


class SurroundingsConfig(FrozenConfig):
    """How the observation becomes the controller's surroundings (what the ego does about blockages is the
    scenario's ``tactics``)."""

    removed_fields: ClassVar[dict[str, str]] = removed_options.SURROUNDINGS

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
    leader_standstill_gap_m: float = Field(2.0, ge=0, description="... plus this gap (the ego keeps its distance)")
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
    route: tuple[str, ...] | None = Field(
        None, description="connected edges it drives (a crossing street); edge_id is then one of them and lane "
        "SUMO's index there (None: the ego's road from edge_id on)")


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


SUMO_PREFIX = "sumo:"


def installed_sumo_file(value: Any) -> Any:
    """``sumo:tools/game/cross/cross.net.xml`` -> that file inside the installed ``eclipse-sumo`` package (read from
    there, not copied: SUMO's licence and OpenStreetMap's); any other value unchanged."""
    if not isinstance(value, str) or not value.startswith(SUMO_PREFIX):
        return value
    import sumo  # the eclipse-sumo wheel's package: its data files, no simulator

    return Path(sumo.__file__).parent / value[len(SUMO_PREFIX):].lstrip("/")


class RouteEnds(FrozenConfig):
    """``road: {from: EDGE, via: [EDGE, ...], to: EDGE}``: SUMO's router finds the edges between (the fastest way
    for a car), through the ``via`` edges in order."""

    model_config = ConfigDict(frozen=True, extra="forbid", populate_by_name=True, allow_inf_nan=False)

    from_edge: str = Field(..., alias="from", min_length=1, description="the edge the ego starts on")
    via: tuple[str, ...] = Field((), description="edges the route passes, in order")
    to_edge: str = Field(..., alias="to", min_length=1, description="the edge its route ends on")


class SumoConfig(FrozenConfig):
    """The SUMO world of a run: network, traffic, the ego's start, obstacles; validated before SUMO starts.

    The seed is the run's (given to :class:`~agentic_mpc.sumo.world.SumoWorld`), not a field here."""

    net_file: Path
    route_files: tuple[Path, ...] = Field(..., min_length=1, description="must define the vTypes used")
    road: str | tuple[str, ...] | RouteEnds = Field(
        ..., description="the ego's road: a start edge (followed while it has one successor), a list of connected "
        "edges, or {from: EDGE, to: EDGE} for the route SUMO's router finds; through junctions the ego follows one "
        "lane of its route (the one that leads on)"
    )
    vehicle_model: Literal["paper", "urban"] = Field(
        "paper", description="the ego's plant: the paper's identified model (highway: it turns no tighter than a 32 m "
        "radius) or 'urban' (the same car able to turn at junctions; agentic_mpc.vehicle.URBAN_PARAMS)")
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
    removed_fields: ClassVar[dict[str, str]] = removed_options.SIMULATION
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
    announce_lane_changes: bool = Field(
        True,
        description="SUMO's drivers told of the ego's lane changes (its plan): followers in the lane it enters asked"
        " to open a gap, braking at most announce_max_decel_mps2 (agentic_mpc.sumo.intention)",
    )
    announce_max_decel_mps2: float = Field(
        2.0, gt=0, le=9.0, description="how hard a SUMO driver asked to open a gap for the ego may brake")
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
        value = (value,) if isinstance(value, (str, Path)) else value
        return tuple(installed_sumo_file(v) for v in value) if isinstance(value, list | tuple) else value

    @field_validator("net_file", mode="before")
    @classmethod
    def _sumo_file(cls, value: Any) -> Any:
        return installed_sumo_file(value)

    @model_validator(mode="after")
    def _unique_ids(self) -> SumoConfig:
        ids = [self.ego_id, *(v.id for v in self.vehicles), *(o.id for o in self.obstacles)]
        duplicates = sorted({i for i in ids if ids.count(i) > 1})
        if duplicates:
            raise ValueError(f"vehicle ids must be unique, duplicated: {duplicates}")
        return self
