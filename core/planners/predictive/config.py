"""Typed configuration of the predictive planner, and the mapping from the reference planner grid.

Every distance is a *margin on top of the true collision geometry* (robot radius + pedestrian
radius from the observation, robot radius vs. static edges): the reference planned with 0.25 m
radii against a 1.0 m robot, which is why its clearance terms were blind to real contacts.
Speeds are ratios of the robot's own limits, so one config serves every robot. Settings are nested
by what they mean; the flat keys of before (``safety.confidence``, ``sampling.turn_then_go``) are
still read, each moved to its place (``OLD_KEYS`` in ``config_keys``). What each default bought,
measured: the planner's history page, docs/history.md (linked below by date).
"""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from foresight.core.errors import ConfigError
from foresight.core.planners.predictive.config_keys import (
    OLD_KEYS,
    REFERENCE_KEY_MAP,
    map_reference_value,
    move_old_keys,
)
from foresight.core.sim.planner import config_hash

__all__ = [
    "MIN_GEODESIC_RESOLUTION",
    "REFERENCE_KEY_MAP",
    "CrowdConfig",
    "NearFieldSampling",
    "PedestrianMargins",
    "PredictivePlannerConfig",
    "SafetyConfig",
    "SamplingConfig",
    "SearchConfig",
    "WeightsConfig",
]


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class _Section(_Frozen):
    """A section that still reads its flat keys of before the nesting (``OLD_KEYS[section]``)."""

    section: ClassVar[str] = ""

    @model_validator(mode="before")
    @classmethod
    def _old_keys(cls, data: Any) -> Any:
        return move_old_keys(data, OLD_KEYS[cls.section], set(cls.model_fields))


def _in_unit(values: tuple[float, ...], low: float = 0.0) -> tuple[float, ...]:
    bad = [r for r in values if not low <= r <= 1.0]
    if bad:
        raise ValueError(f"ratios of a limit must lie in [{low:g}, 1], got {bad}")
    return values


# ---------------------------------------------------------------- sampling


class NearFieldSampling(_Frozen):
    """Denser first candidates where a pedestrian is predicted close: there a small steering difference
    decides between a near miss and a collision."""

    distance: float = Field(default=2.5, ge=0)  #: predicted clearance to contact [m] inside which it applies
    speed_ratios: tuple[float, ...] = (0.1, 0.2, 0.35)  #: slow speeds added, ratios of v_max
    speed_cap: float = Field(default=1.0, gt=0, le=1)  #: every speed capped at this ratio of v_max
    turn_rate_count: int = Field(default=17, ge=3, le=61)  #: evenly spaced turn rates over [-w_max, w_max]
    turn_rates: tuple[float, ...] = ()  #: extra turn rates [rad/s], clipped to +-w_max
    direction_count: int = Field(default=32, ge=4, le=144)  #: a holonomic robot's directions

    @field_validator("speed_ratios")
    @classmethod
    def _ratios(cls, values: tuple[float, ...]) -> tuple[float, ...]:
        return _in_unit(values)


class PointTurns(_Frozen):
    """Turn in place, then drive straight: how a robot in a corner faces a door (a held arc cannot)."""

    #: turned in place at the full turn rate [rad]; () = none (more doors reached: docs/history.md#2026-11-24)
    angles: tuple[float, ...] = (-1.6, -1.2, -0.8, -0.4, 0.4, 0.8, 1.2, 1.6)
    speed_ratios: tuple[float, ...] = (0.25, 0.5)  #: the straight drive after the turn, ratios of v_max

    @field_validator("speed_ratios")
    @classmethod
    def _ratios(cls, values: tuple[float, ...]) -> tuple[float, ...]:
        return _in_unit(values)


class Veers(_Frozen):
    """Swerves: turn at speed for a while, then straight on: how a robot behind slower walkers pulls out and
    passes them (held, the turn is a circle that never enters the beam)."""

    #: ratios of w_max while swerving; () = none (success 0.965 -> 0.974: docs/history.md#2026-11-25)
    turn_rates: tuple[float, ...] = (-1.0, -0.5, 0.5, 1.0)
    speed_ratios: tuple[float, ...] = (0.5, 1.0)  #: driving speeds, ratios of v_max
    durations_s: tuple[float, ...] = (0.8, 1.6)  #: how long each swerve turns [s], then straight on

    @field_validator("speed_ratios")
    @classmethod
    def _ratios(cls, values: tuple[float, ...]) -> tuple[float, ...]:
        return _in_unit(values)

    @field_validator("turn_rates")
    @classmethod
    def _turn_ratios(cls, values: tuple[float, ...]) -> tuple[float, ...]:
        return _in_unit(values, low=-1.0)

    @field_validator("durations_s")
    @classmethod
    def _positive(cls, values: tuple[float, ...]) -> tuple[float, ...]:
        if any(d <= 0 for d in values):
            raise ValueError(f"durations must be positive [s], got {list(values)}")
        return values


class SamplingConfig(_Section):
    """Candidate commands of the first segment, sampled directly in (v, omega) (holonomic: velocities)."""

    section: ClassVar[str] = "sampling"

    speed_ratios: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0)  #: of the robot's max linear speed
    turn_rate_count: int = Field(default=9, ge=3, le=41)  #: evenly spaced turn rates over [-w_max, w_max]
    turn_rates: tuple[float, ...] = ()  #: extra turn rates [rad/s], clipped to +-w_max
    #: a holonomic robot's candidates: ``speed_ratios`` x this many directions around it (CrowdNav's: 16)
    direction_count: int = Field(default=16, ge=4, le=72)
    #: backing off, ratios of v_max, where ``robot_config.allow_backwards``; () = never (stress suite 244 ->
    #: 237 solved with it: robots backed away until time ran out, docs/history.md#2026-11-28)
    reverse_speed_ratios: tuple[float, ...] = ()
    near_field: NearFieldSampling = NearFieldSampling()
    point_turns: PointTurns = PointTurns()
    veers: Veers = Veers()

    @field_validator("speed_ratios", "reverse_speed_ratios")
    @classmethod
    def _ratios(cls, values: tuple[float, ...]) -> tuple[float, ...]:
        return _in_unit(values)


# ---------------------------------------------------------------- search


class SearchConfig(_Frozen):
    """Beam search over piecewise-constant command sequences on the forecast's time grid."""

    segments_s: tuple[float, ...] = (0.8,)  #: durations of segments 1..S-1 [s]; the last lasts to the horizon
    #: the forecast extended at its final velocity [s]: 2.4 + 1.6 s lets the robot clear a walker's path
    extra_horizon_s: float = Field(default=1.6, ge=0, le=5)
    beam_width: int = Field(default=6, ge=1, le=64)  #: sequences kept after each segment
    branch_speed_ratios: tuple[float, ...] = (0.0, 0.5, 1.0)  #: later-segment speeds, ratios of max speed
    branch_turn_rate_count: int = Field(default=5, ge=1, le=21)  #: later-segment turn rates over +-w_max
    branch_direction_count: int = Field(default=8, ge=4, le=72)  #: holonomic later-segment directions
    #: grid [m] of the route potential around walls; 0 = straight (fewer solved: docs/history.md#2026-11-24)
    geodesic_resolution: float = Field(default=0.1, ge=0, le=1)
    #: the last plan, one step on, is a candidate (no flip-flops: 2-4 % less time, docs/history.md#2026-11-25)
    keep_plan: bool = True
    #: an earlier arrival counts v_max x time left [m] as progress (5-7 % faster: docs/history.md#2026-11-25)
    arrival_credit: bool = True
    #: steps after a rollout reached the goal cost nothing: the episode ends (docs/history.md#2026-11-28)
    ends_at_goal: bool = True
    #: lengthen the horizon by ``horizon_boost_s`` [s] in the near field (the reference grid uses it)
    adaptive_horizon: bool = False
    horizon_boost_s: float = Field(default=0.0, ge=0, le=5)  #: [s]; 0 = no boost

    @model_validator(mode="after")
    def _bounded_grid(self) -> SearchConfig:
        # a finer grid grows as 1 / resolution^2 (a 44 x 28 m map at 0.01 m: 12 million nodes per waypoint)
        if 0 < self.geodesic_resolution < MIN_GEODESIC_RESOLUTION:
            raise ValueError(
                f"geodesic_resolution must be 0 (straight lines) or at least {MIN_GEODESIC_RESOLUTION} m, "
                f"got {self.geodesic_resolution}"
            )
        return self


#: the finest grid [m] of the route potential's distances around the walls (bounded work and memory per map)
MIN_GEODESIC_RESOLUTION = 0.05


# ---------------------------------------------------------------- safety


class PedestrianMargins(_Frozen):
    """Clearance to pedestrians [m] on top of the true radii, widened by the forecast's spread (sigma)."""

    extra_robot_margin: float = Field(default=0.0, ge=0)  #: added to the robot radius (reference grid)
    extra_ped_margin: float = Field(default=0.0, ge=0)  #: added to the pedestrian radius (reference grid)
    collision_margin: float = Field(default=0.1, ge=0)  #: inside it a step counts as a (predicted) collision
    #: chance margin in forecast standard deviations (0.5 doubled collisions: docs/history.md#2026-11-29)
    confidence: float = Field(default=1.0, ge=0, le=4)
    near_distance: float = Field(default=0.5, ge=0)  #: near-miss band beyond the collision distance
    ttc_distance: float = Field(default=0.4, ge=0)  #: a step inside it ends the time to collision
    hard_clearance_distance: float = Field(default=0.3, ge=0)  #: hard clearance band (``weights``)
    progress_risk_distance: float = Field(default=0.8, ge=0)  #: progress closer than it is risky progress
    speed_clearance_gain: float = Field(default=0.25, ge=0)  #: extra margin per robot speed [m per m/s]
    discount: float = Field(default=0.9, gt=0, le=1)  #: weight of each later forecast step's pedestrian terms


class StaticMargins(_Frozen):
    """Clearance to walls and obstacles [m] on top of the robot radius."""

    margin: float = Field(default=0.05, ge=0)  #: hard: rollouts closer to an edge are infeasible
    soft_distance: float = Field(default=0.4, ge=0)  #: soft clearance band beyond the hard margin
    field_resolution: float = Field(default=0.1, ge=0, le=0.5)  #: distance field grid [m]; 0 = exact queries


class StallConfig(_Frozen):
    """Assertiveness 0..1 that ramps up while the robot makes no route progress: a robot that waits for
    pedestrians who wait for it stalls forever, so after a stall the soft pedestrian margins shrink."""

    after_s: float = Field(default=2.0, gt=0)  #: window over which route progress is measured [s]
    ramp_s: float = Field(default=3.0, gt=0)  #: time for assertiveness to move between 0 and 1 [s]
    progress: float = Field(default=0.5, gt=0)  #: less route progress [m] in the window is a stall
    margin_relief: float = Field(default=0.5, ge=0, le=1)  #: share of the soft margins dropped at full stall


class Yielding(_Frozen):
    """Yield, then commit: after a stall a pedestrian standing beside the robot is taken to wait for it and
    to step away as it edges forward, until seen to hold their ground (doorways 6 -> 17 / 30 solved:
    docs/history.md#2026-11-24)."""

    speed: float = Field(default=0.3, ge=0)  #: how fast [m/s] they step away; 0 = nobody is trusted to
    test_s: float = Field(default=3.0, gt=0)  #: one that stays put this long [s] as the robot nears holds


class Receding(_Frozen):
    """Walkers walking away from a slow robot do not walk into it: a robot held up behind them may pass
    closer (a fast one keeps full margins: walkers who do not see it turn into it at waypoints;
    docs/history.md#2026-11-25)."""

    room: float = Field(default=0.5, ge=0)  #: their clearance counts this much larger [m]; 0 = off
    speed: float = Field(default=0.3, gt=0)  #: in full from this speed away [m/s], linearly less down to 0
    max_robot_speed: float = Field(default=0.8, gt=0, le=1)  #: in full below half of it x v_max, none from it


class StraightLines(_Frozen):
    """Walkers closing in on a slow robot, not seen to give way, are also held to the straight line of their
    velocity (one who does not see the robot walks on into it). Off by default: collisions where nobody yields
    12 -> 7, but typical speed lost 19 : 1 (docs/history.md#2026-11-25)."""

    speed: float = Field(default=0.0, ge=0)  #: closing speed [m/s] from which it applies; 0 = off
    max_robot_speed: float = Field(default=0.4, gt=0, le=1)  #: only below it (ratio of v_max)


class CrowdConfig(_Frozen):
    """What the planner assumes about pedestrians beyond their forecast (``crowd``), by assumption."""

    standing_speed: float = Field(default=0.25, ge=0)  #: slower than this [m/s] a pedestrian stands
    beside_distance: float = Field(default=1.2, ge=0)  #: within this of contact [m] one is beside the robot
    #: [s] one beside the robot this long, moved < 0.5 m, keeps its own velocity (not the model's walk-off);
    #: 0 = off (stress suite collisions 7 -> 5: docs/history.md#2026-11-28)
    lingering_s: float = Field(default=1.5, ge=0)
    #: room [m] x stall assertiveness made by one forecast to stand; 0 = off (x4 collisions:
    #: docs/history.md#2026-11-24)
    waiting_room: float = Field(default=0.0, ge=0)
    #: how long a walker's pass is remembered for the lane cost (``weights.lane``), decay time [s]
    lane_memory_s: float = Field(default=20.0, gt=0)
    yielding: Yielding = Yielding()
    receding: Receding = Receding()
    straight: StraightLines = StraightLines()


class SafetyConfig(_Section):
    """Margins to pedestrians and walls, how a stall relaxes them, and what the crowd is assumed to do."""

    section: ClassVar[str] = "safety"

    pedestrians: PedestrianMargins = PedestrianMargins()
    static: StaticMargins = StaticMargins()
    stall: StallConfig = StallConfig()
    crowd: CrowdConfig = CrowdConfig()


# ---------------------------------------------------------------- weights


class PedestrianWeights(_Frozen):
    """Weights of the pedestrian terms (``cost.pedestrian_terms``)."""

    collision: float = Field(default=60.0, ge=0)  #: per metre inside the collision margin, per step
    risk: float = Field(default=80.0, ge=0)  #: per expected contact step (probability summed over steps)
    near_miss: float = Field(default=2.0, ge=0)
    ttc: float = Field(default=6.0, ge=0)
    progress_risk: float = Field(default=3.0, ge=0)
    hard_clearance: float = Field(default=20.0, ge=0)


class StaticWeights(_Frozen):
    """Weights of the wall and obstacle terms."""

    clearance: float = Field(default=3.0, ge=0)  #: soft static clearance (the ``static`` term)
    collision: float = Field(default=1000.0, ge=0)  #: per infeasible step (too close to an edge)


class MotionWeights(_Frozen):
    """Weights of the terms on the commands themselves."""

    velocity: float = Field(default=0.0, ge=0)  #: mean speed (reference grid)
    turn: float = Field(default=0.1, ge=0)  #: mean turn rate
    smoothness: float = Field(default=0.3, ge=0)  #: change of the first command from the last one


class WeightsConfig(_Section):
    """Cost weights (lower cost is better); see ``core.planners.predictive.cost`` for the terms."""

    section: ClassVar[str] = "weights"

    goal: float = Field(default=6.0, ge=0)  #: per metre of route progress
    heading: float = Field(default=1.0, ge=0)  #: mean heading error to the active waypoint over the horizon
    lane: float = Field(default=2.0, ge=0)  #: per walker lately where a rollout ends at rest (``traffic``)
    pedestrians: PedestrianWeights = PedestrianWeights()
    static: StaticWeights = StaticWeights()
    motion: MotionWeights = MotionWeights()

    def by_term(self) -> dict[str, float]:
        """Each cost term's weight by the term's name (``cost.TERMS``; ``progress`` at the goal weight)."""
        p, s, m = self.pedestrians, self.static, self.motion
        return {
            "progress": self.goal,
            "collision": p.collision,
            "risk": p.risk,
            "near_miss": p.near_miss,
            "ttc": p.ttc,
            "progress_risk": p.progress_risk,
            "hard_clearance": p.hard_clearance,
            "static": s.clearance,
            "static_collision": s.collision,
            "velocity": m.velocity,
            "turn": m.turn,
            "smoothness": m.smoothness,
            "heading": self.heading,
            "lane": self.lane,
        }


# ---------------------------------------------------------------- the whole


class PredictivePlannerConfig(_Frozen):
    """The predictive planner's full configuration; ``resolved()`` and ``config_hash()`` identify a run."""

    max_speed_ratio: float = Field(default=1.0, gt=0, le=1)  #: of the robot's max linear speed
    sampling: SamplingConfig = SamplingConfig()
    search: SearchConfig = SearchConfig()
    safety: SafetyConfig = SafetyConfig()
    weights: WeightsConfig = WeightsConfig()

    def resolved(self) -> dict[str, Any]:
        """Every key, defaults expanded (JSON types), for provenance and key-by-key A/B comparison."""
        return self.model_dump(mode="json")

    def config_hash(self) -> str:
        """sha256 of the canonical JSON of :meth:`resolved` (the hash every run records)."""
        return config_hash(self.resolved())

    @classmethod
    def from_dict(cls, data: dict[str, Any] | None, source: str | None = None) -> PredictivePlannerConfig:
        """Validate a nested dict (YAML/API body); unknown keys are a ConfigError naming them."""
        try:
            return cls.model_validate(data or {})
        except ValidationError as exc:
            err = exc.errors()[0]
            item = ".".join(str(p) for p in err["loc"])
            raise ConfigError(
                f"{err['msg']} ({len(exc.errors())} error(s))", source=source, item=item
            ) from None

    @classmethod
    def upgrade_keys(cls, data: dict[str, Any]) -> dict[str, Any]:
        """``data`` with the flat keys of before moved to their places, as validation moves them, so that it
        can be merged key by key over a config in today's keys (a campaign's grid variant over its base)."""
        out = dict(data)
        for section, moved in OLD_KEYS.items():
            if isinstance(out.get(section), dict):
                fields = set(cls.model_fields[section].annotation.model_fields)
                try:
                    out[section] = move_old_keys(out[section], moved, fields)
                except ValueError as exc:
                    raise ConfigError(str(exc), item=section) from None
        return out

    @classmethod
    def from_reference_grid(
        cls, params: dict[str, Any], base: PredictivePlannerConfig | None = None, source: str | None = None
    ) -> PredictivePlannerConfig:
        """Map one reference grid variant's ``params`` onto ``base`` (default: our defaults).

        See :data:`REFERENCE_KEY_MAP`; an unmappable key is a ConfigError naming it.
        """
        data = (base or cls()).model_dump()
        for key, value in params.items():
            rule = REFERENCE_KEY_MAP.get(key)
            if rule is None:
                mapped = ", ".join(sorted(REFERENCE_KEY_MAP))
                raise ConfigError(
                    f"reference planner key {key!r} has no mapping (mapped keys: {mapped})",
                    source=source,
                    item=key,
                )
            path, kind, ref_value = rule
            *parents, field = path.split(".")
            target = data
            for part in parents:
                target = target[part]
            target[field] = map_reference_value(key, value, kind, ref_value, target[field], source)
        return cls.from_dict(data, source=source)
