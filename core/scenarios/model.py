"""Scenario and scenario-matrix config models (pydantic), defined once and reused by YAML, API and CLI.

Every model forbids unknown keys, so an unsupported key is reported by name instead of being
silently ignored (the reference ignored e.g. ``groups``). Free-form data goes in ``metadata``.
Defaults are the reference (robot_sf) defaults; units in brackets.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from foresight.core.maps.model import MapDef, Point, Role, WaitRule
from foresight.core.scenarios.crowd_models import CrowdGenerator, OrcaPedestrians

#: most steps of one episode anywhere (scenario horizon, evaluation and collection ``max_steps``)
MAX_EPISODE_STEPS = 100_000


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


ResponseLaw = Literal["reactive", "non_reactive", "non_yielding", "hesitating"]


class PedRobotForceConfig(_Strict):
    """robot_sf's ``prf_config``: the robot repulsion felt by pedestrians, calibrated per scenario."""

    is_active: bool = True  #: False = no robot repulsion (as ``peds_have_robot_repulsion: false``)
    robot_radius: float = Field(default=1.0, gt=0)  #: robot radius in the force's cutoff [m]
    activation_threshold: float = Field(default=2.0, gt=0)  #: cutoff = this + 0.35 + robot_radius [m]
    force_multiplier: float = 10.0  #: factor of the 1/d^3 repulsion


def _fractions(value: dict[str, float] | None, what: str) -> dict[str, float] | None:
    """A composition: positive shares summing to 1 (robot_sf's check)."""
    if value is None:
        return None
    if not value or any(not v > 0 for v in value.values()):
        raise ValueError(f"{what} needs positive shares")
    if abs(sum(value.values()) - 1.0) > 1e-6:
        raise ValueError(f"{what} shares must sum to 1 (got {sum(value.values()):g})")
    return value


class SimulationConfig(_Strict):
    """Crowd and episode settings of one scenario (YAML ``simulation_config``)."""

    dt: float = Field(default=0.1, gt=0, le=1.0)  #: simulation step [s]
    max_episode_steps: int = Field(
        default=2000, ge=1, le=MAX_EPISODE_STEPS
    )  #: horizon: exactly this many steps, then timeout
    ped_density: float = Field(
        default=0.01, ge=0, le=2.0
    )  #: peds per m^2 of spawnable area (route length x 3 m + crowded zones)
    difficulty: int = Field(default=0, ge=0)  #: accepted for reference compatibility; density is set directly
    max_peds_per_group: int = Field(default=3, ge=1, le=20)
    peds_speed_mult: float = Field(
        default=1.3, gt=0
    )  #: desired speed = mult x spawn speed (0.5 m/s) -> 0.65 m/s
    #: desired speeds: reference = peds_speed_mult x 0.5 m/s; tiers draw from a normal (core.sim.params.SPEED_TIERS),
    #: ``realistic`` = measured walking speeds N(1.34, 0.26) m/s
    ped_speed_tier: Literal["reference", "slow", "typical", "brisk", "realistic"] = "reference"
    ped_radius: float = Field(default=0.4, gt=0)  #: collision radius [m]
    goal_radius: float = Field(default=1.0, ge=0)  #: robot goal tolerance = robot radius + this [m]
    route_spawn_distribution: Literal["cluster", "spread"] = "cluster"
    route_spawn_jitter_frac: float = Field(default=0.0, ge=0, le=1)
    route_spawn_seed: int | None = None  #: default: the episode seed
    pedestrian_integration_scheme: Literal["semi_implicit_euler", "explicit_euler"] = "semi_implicit_euler"
    zone_sampling: Literal["triangle", "full"] = (
        "triangle"  #: triangle = the reference's half-rectangle reading
    )
    peds_have_obstacle_forces: bool = True
    peds_have_robot_repulsion: bool = True
    nonreactive_fraction: float = Field(
        default=0.0, ge=0, le=1
    )  #: share of peds that ignore the robot entirely
    late_reaction_fraction: float = Field(
        default=0.0, ge=0, le=1
    )  #: share of the other peds that notice it late
    late_reaction_distance: float = Field(
        default=2.0, gt=0
    )  #: centre distance at which a late ped reacts [m]
    #: clearance [m] beyond contact that pedestrians keep from the robot where they spawn: at the start (groups that
    #: would start nearer are placed elsewhere on their route) and when they respawn (a group waits while the robot
    #: is that near its spawn zone; a replayed track that would begin that near is left out). None = the reference's
    #: 0.5 m. A walker placed 0.5 m from a robot and heading at it collides within a second whatever the planner does
    robot_spawn_clearance: float | None = Field(default=None, ge=0, le=10)
    population_size: int | None = Field(default=None, ge=0, le=5000)  #: force an exact route+zone ped count
    groups: float | None = Field(
        default=None, ge=0, le=1
    )  #: reference group_crossing share; read by no physics (like the reference)
    #: route/zone peds re-placed in their route's spawn zone at reset, heading for its first waypoint
    peds_reset_follow_route_at_start: bool = False
    #: heterogeneous walkers (robot_sf): share of each archetype, and its desired-speed factor
    archetype_composition: dict[str, float] | None = None
    archetype_speed_factors: dict[str, float] | None = None
    archetype_seed: int | None = None  #: default: drawn from the episode seed
    #: how route/zone peds respond to the robot: share per law; the law scales the robot repulsion
    response_law_composition: dict[ResponseLaw, float] | None = None
    response_law_seed: int | None = None  #: default: drawn from the episode seed
    non_reactive_response_multiplier: float = Field(default=0.0, ge=0)  #: non_reactive / non_yielding
    hesitating_response_multiplier: float = Field(default=1.0, ge=0)
    prf_config: PedRobotForceConfig | None = None
    #: how pedestrians move: the social-force crowd, or ORCA agents (``orca``; CrowdNav's humans)
    pedestrian_model: Literal["social_force", "orca"] = "social_force"
    orca: OrcaPedestrians = OrcaPedestrians()  #: read where pedestrian_model is orca
    #: robot-pedestrian contact: ``discrete`` at each step's positions; ``swept`` also between them (both moving
    #: straight over the step), as CrowdNav checks the segment travelled
    collision_check: Literal["discrete", "swept"] = "discrete"

    @model_validator(mode="before")
    @classmethod
    def _reference_spellings(cls, data: Any) -> Any:
        if isinstance(data, dict):
            data = dict(data)
            if data.get("route_spawn_distribution") == "uniform":  # uniform anchors along the route = cluster
                data["route_spawn_distribution"] = "cluster"
            misplaced = data.pop("robot_config", None)  # robot_sf files that put an empty robot_config here
            if misplaced:
                raise ValueError("robot_config belongs at scenario level, not in simulation_config")
        return data

    @model_validator(mode="after")
    def _compositions(self) -> SimulationConfig:
        _fractions(self.archetype_composition, "archetype_composition")
        _fractions(self.response_law_composition, "response_law_composition")
        if (self.archetype_composition is None) != (self.archetype_speed_factors is None):
            raise ValueError("archetype_composition and archetype_speed_factors come together")
        if self.archetype_composition is not None:
            missing = sorted(set(self.archetype_composition) - set(self.archetype_speed_factors or {}))
            if missing:
                raise ValueError(f"archetype_speed_factors lacks {', '.join(missing)}")
            if any(not f > 0 for f in (self.archetype_speed_factors or {}).values()):
                raise ValueError("archetype_speed_factors must be positive")
        return self


Kinematics = Literal["differential_drive", "unicycle", "holonomic"]
MAX_COMMAND_LATENCY_S = 5.0  #: the longest command latency a scenario may ask for [s]


class RobotConfig(_Strict):
    """Robot kinematics (YAML ``robot_config``; ``{}`` = the reference's differential drive).

    ``kinematics`` (alias ``type``): ``differential_drive`` takes (v, omega) with midpoint odometry;
    ``unicycle`` takes (v, omega) and turns before it moves, as CrowdNav's unicycle robot; ``holonomic``
    takes a world-frame velocity (vx, vy). Accelerations are limits of every kind (a large value = none).
    """

    kinematics: Kinematics = "differential_drive"
    radius: float = Field(default=1.0, gt=0)  #: [m]
    max_linear_speed: float = Field(default=2.0, gt=0)  #: [m/s]
    #: the speed planners cruise at [m/s]; None = max_linear_speed
    preferred_speed: float | None = Field(default=None, gt=0)
    max_angular_speed: float = Field(default=1.0, gt=0)  #: [rad/s]
    max_linear_accel: float = Field(default=1.0, gt=0)  #: [m/s^2]
    max_linear_decel: float | None = Field(default=None, gt=0)  #: [m/s^2]; None = max_linear_accel
    max_angular_accel: float = Field(default=1.0, gt=0)  #: [rad/s^2]
    wheel_radius: float = Field(
        default=0.05, gt=0
    )  #: [m] (reference compatibility; unused by our kinematics)
    interaxis_length: float = Field(default=0.3, gt=0)  #: [m] (reference compatibility; unused)
    allow_backwards: bool = False
    actuation: Literal["tracking", "reference_lag"] = "tracking"  #: see core.sim.robot
    #: [s] a command takes effect this long after it is issued (core.sim.latency); 0 = at once
    command_latency_s: float = Field(default=0.0, ge=0, le=MAX_COMMAND_LATENCY_S)

    @model_validator(mode="before")
    @classmethod
    def _aliases(cls, data: Any) -> Any:
        if isinstance(data, dict):
            data = dict(data)
            for alias in ("type", "model"):  # earlier spellings of kinematics
                if alias in data:
                    if "kinematics" in data:
                        raise ValueError(f"give kinematics or its alias {alias}, not both")
                    data["kinematics"] = data.pop(alias)
            for old, new in (("max_robot_speed", "max_linear_speed"), ("robot_radius", "radius")):
                if old in data:  # names used by robot_sf's older robot settings
                    if new in data:
                        raise ValueError(f"give {new} or its alias {old}, not both")
                    data[new] = data.pop(old)
            alias = {"diff": "differential_drive", "omni": "holonomic"}
            if data.get("kinematics") in alias:
                data["kinematics"] = alias[data["kinematics"]]
        return data

    @model_validator(mode="after")
    def _preferred_within_max(self) -> RobotConfig:
        if self.preferred_speed is not None and self.preferred_speed > self.max_linear_speed:
            raise ValueError(
                f"preferred_speed {self.preferred_speed:g} m/s exceeds max_linear_speed {self.max_linear_speed:g}"
            )
        return self

    @property
    def type(self) -> str:
        """The kinematics under its earlier name."""
        return self.kinematics

    @property
    def decel(self) -> float:
        return self.max_linear_decel if self.max_linear_decel is not None else self.max_linear_accel

    @property
    def v_pref(self) -> float:
        return self.preferred_speed if self.preferred_speed is not None else self.max_linear_speed


class SinglePedestrianOverride(_Strict):
    """Scenario-level override of a map's single pedestrian, matched by ``id``.

    An id the map lacks defines a new pedestrian when the entry gives its ``start``. ``goal_poi``
    and ``trajectory_poi`` name the map's points of interest (label or id) instead of coordinates.
    """

    id: str
    start: Point | None = None
    goal: Point | None = None
    goal_poi: str | None = None
    trajectory: tuple[Point, ...] | None = None
    trajectory_poi: tuple[str, ...] | None = None
    speed_m_s: float | None = Field(default=None, ge=0)
    wait_at: tuple[WaitRule, ...] | None = None
    start_delay_s: float | None = Field(default=None, ge=0)
    note: str | None = None
    role: Role | None = None
    role_target_id: str | None = None
    role_offset: Point | None = None
    hold_until_robot_within_m: float | None = Field(default=None, gt=0)
    hold_ref_point: Point | None = None
    hold_timeout_s: float | None = Field(default=None, gt=0)
    metadata: dict[str, Any] | None = None

    @model_validator(mode="after")
    def _one_way_per_point(self) -> SinglePedestrianOverride:
        for a, b in (("goal", "goal_poi"), ("trajectory", "trajectory_poi")):
            if {a, b} <= self.model_fields_set:
                raise ValueError(f"give {a} or {b}, not both")
        return self


class RouteSpec(_Strict):
    """One route of a route override: zone indices (None or one the map lacks: a 0.1 m zone at the end), waypoints."""

    spawn_id: int | None = Field(default=None, ge=0)
    goal_id: int | None = Field(default=None, ge=0)
    waypoints: tuple[Point, ...] = Field(min_length=2)


class RouteOverrides(_Strict):
    """Routes that replace the map's robot and/or pedestrian routes (an empty list keeps the map's)."""

    robot_routes: tuple[RouteSpec, ...] = ()
    ped_routes: tuple[RouteSpec, ...] = ()


class ReplayPedestrian(_Strict):
    id: str = Field(min_length=1)
    start: Point
    trajectory: tuple[Point, ...] = ()


class ReplayRobot(_Strict):
    start: Point
    goal: Point
    trajectory: tuple[Point, ...] = ()  #: the recorded robot path: provenance only (the planner drives)


class GeneratedReplay(_Strict):
    """robot_sf's generated-scenario replay: scripted pedestrians along recorded paths, the robot's start and goal."""

    schema_version: Literal["robot_sf.generated_replay_runtime.v1"] = "robot_sf.generated_replay_runtime.v1"
    pedestrians: tuple[ReplayPedestrian, ...] = ()
    robot: ReplayRobot | None = None


class SemanticRegion(_Strict):
    """A hazard or keep-clear region: a bbox [min_x, min_y, max_x, max_y] or a polygon (robot_sf's checks)."""

    id: str = Field(min_length=1)
    kind: Literal["hazard", "keep_clear"]
    shape: Literal["polygon", "bbox"]
    bounds: tuple[float, float, float, float] | None = None
    points: tuple[Point, ...] | None = None
    note: str | None = None
    metadata: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _geometry(self) -> SemanticRegion:
        if self.shape == "bbox" and (
            self.bounds is None or not (self.bounds[0] < self.bounds[2] and self.bounds[1] < self.bounds[3])
        ):
            raise ValueError(
                f"region {self.id!r}: a bbox needs bounds [min_x, min_y, max_x, max_y] with min < max"
            )
        if self.shape == "polygon" and (self.points is None or len(self.points) < 3):
            raise ValueError(f"region {self.id!r}: a polygon needs at least 3 points")
        return self


class PlatformSemantics(_Strict):
    """Hazard / keep-clear regions robot_sf records for provenance; no consumer reads them (its status says so)."""

    status: Literal["metadata_only"] = "metadata_only"
    regions: tuple[SemanticRegion, ...] = Field(min_length=1)


class ObservationVisibility(_Strict):
    """Which pedestrians the planner sees: field of view around the heading, range, walls in the line of sight."""

    enabled: bool = True
    fov_degrees: float = Field(default=360.0, gt=0, le=360)
    max_range_m: float | None = Field(default=None, gt=0)
    static_occlusion: bool = False  #: obstacle edges between robot and pedestrian hide it
    dynamic_occlusion: Literal[False] = False  #: pedestrians hiding each other: not modelled

    @property
    def active(self) -> bool:
        return self.enabled and (
            self.fov_degrees < 360 or self.max_range_m is not None or self.static_occlusion
        )


class ReplayConfig(_Strict):
    """Recorded pedestrians replayed along their tracks instead of a simulated crowd (``core.scenarios.replay``).

    The scene is the ETH/UCY file ``<data root>/raw/all_data/<scene>.txt``; the episode starts at its annotated
    frame ``start_frame`` and lasts the scenario's horizon. The map is the scene's walkable bounds (every recorded
    position plus ``margin``), with no obstacles; ``robot_start``/``robot_goal`` are in the scene's own coordinates.
    """

    data_root: str = Field(
        default="ethucy", pattern=r"^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$"
    )  #: a named data root
    scene: str = Field(
        min_length=1, pattern=r"^[A-Za-z0-9][A-Za-z0-9._-]*$"
    )  #: scene file stem, e.g. crowds_zara01
    start_frame: int = Field(ge=0)  #: the scene's frame number at which the episode starts (annotated)
    frame_dt: float = Field(default=0.4, gt=0)  #: seconds per annotation (10 frame units) [s]
    robot_start: Point  #: [m], scene coordinates
    robot_goal: Point  #: [m], scene coordinates
    margin: float = Field(default=2.0, ge=0)  #: map bounds beyond the recorded positions [m]


class Scenario(_Strict):
    """One scenario entry of a matrix: a map plus crowd, robot and seed settings (or a replayed scene)."""

    name: str = Field(min_length=1)
    map_file: str | None = None
    map_id: str | None = None
    simulation_config: SimulationConfig = SimulationConfig()
    robot_config: RobotConfig = RobotConfig()
    single_pedestrians: tuple[SinglePedestrianOverride, ...] = ()
    metadata: dict[str, Any] = Field(default_factory=dict)
    seeds: tuple[Annotated[int, Field(ge=0, le=2**32 - 1)], ...] = Field(default=(0,), min_length=1)
    required_map_profile: str = "robot_runtime"  #: registry capability a map_id must have (reference key)
    replay: ReplayConfig | None = None  #: replayed recorded pedestrians; the map comes from the scene
    route_overrides_file: str | None = (
        None  #: YAML with robot_routes/ped_routes (or a route_payload holding them)
    )
    route_overrides: RouteOverrides | None = None  #: the same inline (applied after the file's)
    generated_replay: GeneratedReplay | None = None
    observation_visibility: ObservationVisibility | None = None
    #: humans and robot start/goal drawn by CrowdNav's rules (``core.scenarios.crowd_models``); the map's zones and
    #: routes are then unused
    crowd_generator: CrowdGenerator | None = None
    platform_semantics: PlatformSemantics | None = None
    scenario_family: str | None = None  #: a label, like metadata.archetype

    @model_validator(mode="before")
    @classmethod
    def _scenario_id_alias(cls, data: Any) -> Any:
        if isinstance(data, dict) and "scenario_id" in data and "name" not in data:
            data = dict(data)
            data["name"] = data.pop("scenario_id")
        if isinstance(data, dict) and "multi_amv" in data:
            raise ValueError(
                "multi_amv: Foresight simulates one robot; robot_sf's multi-robot scenarios cannot be run"
            )
        return data

    @model_validator(mode="after")
    def _has_map(self) -> Scenario:
        if self.replay is not None:
            if self.map_file or self.map_id or self.single_pedestrians:
                raise ValueError(
                    "a replay scenario's map and pedestrians come from its scene: no map_file, map_id "
                    "or single_pedestrians"
                )
        elif not self.map_file and not self.map_id:
            raise ValueError("a scenario needs map_file or map_id")
        gen = self.crowd_generator
        if gen is not None and self.simulation_config.pedestrian_model != "orca":
            raise ValueError(
                "crowd_generator: CrowdNav's humans are ORCA agents (simulation_config.pedestrian_model: orca)"
            )
        if gen is not None and (self.replay is not None or self.single_pedestrians):
            raise ValueError(
                "crowd_generator: the generated humans are the only pedestrians (no replay, no single_pedestrians)"
            )
        return self

    @property
    def archetype(self) -> str:
        """Family name for aggregation (metadata.archetype, else the name without its density suffix)."""
        if self.metadata.get("archetype"):
            return str(self.metadata["archetype"])
        for suffix in ("_low", "_medium", "_high"):
            if self.name.endswith(suffix):
                return self.name[: -len(suffix)]
        return self.name

    @property
    def conflict_point(self) -> tuple[float, float] | None:
        """metadata.public_requirement.event_contract.conflict_point: robot_sf's default hold reference point."""
        node: Any = self.metadata
        for key in ("public_requirement", "event_contract", "conflict_point"):
            node = node.get(key) if isinstance(node, dict) else None
        return (float(node[0]), float(node[1])) if isinstance(node, list | tuple) and len(node) == 2 else None

    @property
    def density_label(self) -> str | None:
        d = self.metadata.get("density")
        return str(d) if d is not None else None


@dataclass(frozen=True, eq=False)
class ReplayTracks:
    """The annotations of a replay scenario's window, sorted by (id, time), in the map frame."""

    step: (
        np.ndarray
    )  #: (R,) annotation instants in simulator steps since the start (whole when dt divides frame_dt)
    ids: np.ndarray  #: (R,) int64 pedestrian ids of the scene file
    xy: np.ndarray  #: (R, 2) positions [m], map frame = scene frame - offset
    offset: tuple[float, float]  #: scene coordinates of the map origin [m]


class ResolvedScenario(BaseModel):
    """A scenario with its map loaded and its single-pedestrian overrides applied: what the simulator runs."""

    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True)

    scenario: Scenario
    map: MapDef
    map_sha256: str | None = (
        None  #: checksum of the map source file (a replay: of its scene file), for provenance
    )
    replay: ReplayTracks | None = None  #: the recorded tracks of a replay scenario, in the map frame

    @property
    def name(self) -> str:
        return self.scenario.name


class ScenarioMatrix(BaseModel):
    """A loaded matrix: resolved scenarios in file order, plus where it came from."""

    model_config = ConfigDict(frozen=True)

    source: str
    scenarios: tuple[ResolvedScenario, ...]
    metadata: dict[str, Any] = Field(default_factory=dict)

    def get(self, name: str) -> ResolvedScenario:
        for s in self.scenarios:
            if s.name == name:
                return s
        import difflib

        from foresight.core.errors import NotFoundError

        close = difflib.get_close_matches(name, self.names, n=3)
        hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
        raise NotFoundError(
            f"{self.source}: no scenario named {name!r}{hint} (have: {', '.join(self.names)})"
        )

    @property
    def names(self) -> list[str]:
        return [s.name for s in self.scenarios]
