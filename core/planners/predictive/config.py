"""Typed configuration of the predictive planner, and the mapping from the reference planner grid.

Every distance is a *margin on top of the true collision geometry* (robot radius + pedestrian
radius from the observation, robot radius vs. static edges): the reference planned with 0.25 m
radii against a 1.0 m robot, which is why its clearance terms were blind to real contacts.
Speeds are ratios of the robot's own limits, so one config serves every robot.
"""

from __future__ import annotations

import math
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from foresight.core.errors import ConfigError
from foresight.core.sim.planner import config_hash


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class SamplingConfig(_Frozen):
    """Candidate commands of the first segment, sampled directly in (v, omega)."""

    speed_ratios: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0)  #: of the robot's max linear speed
    turn_rate_count: int = Field(default=9, ge=3, le=41)  #: evenly spaced turn rates over [-w_max, w_max]
    turn_rates: tuple[float, ...] = ()  #: extra turn rates [rad/s], clipped to +-w_max
    near_field_distance: float = Field(default=2.5, ge=0)  #: predicted clearance [m] that densifies the set
    near_field_turn_rate_count: int = Field(default=17, ge=3, le=61)
    near_field_turn_rates: tuple[float, ...] = ()  #: extra near-field turn rates [rad/s]
    near_field_speed_ratios: tuple[float, ...] = (0.1, 0.2, 0.35)
    near_field_speed_cap: float = Field(default=1.0, gt=0, le=1)  #: speed ratio cap inside the near field
    #: a holonomic robot's candidates are velocities: ``speed_ratios`` x these many directions evenly around the
    #: robot (CrowdNav's action set: 16), denser in the near field
    direction_count: int = Field(default=16, ge=4, le=72)
    near_field_direction_count: int = Field(default=32, ge=4, le=144)
    #: point turns: turn in place by each angle [rad], then drive straight at each speed ratio (``sampling.turn_then_go``;
    #: () = none): how a robot in a corner faces a door; more successes at reference speed (see the planner history in the docs)
    turn_then_go: tuple[float, ...] = (-1.6, -1.2, -0.8, -0.4, 0.4, 0.8, 1.2, 1.6)
    turn_then_go_speeds: tuple[float, ...] = (0.25, 0.5)
    #: swerves: drive at each of ``veer_speeds`` x v_max turning at each of ``veer_turn_rates`` x w_max for each of
    #: ``veer_durations_s``, then straight on: a robot behind slower walkers pulls out and passes them (held, such a
    #: turn is a circle that never enters the beam, so robots followed a file of walkers at 0.6 m/s); () = none;
    #: 0.8 and 1.6 s turns: more successes, 2-5 % less time to the goal (see the planner history in the docs)
    veer_turn_rates: tuple[float, ...] = (-1.0, -0.5, 0.5, 1.0)
    veer_speeds: tuple[float, ...] = (0.5, 1.0)
    veer_durations_s: tuple[float, ...] = (
        0.8,
        1.6,
    )  #: how long each swerve turns [s] before it drives straight on
    #: backing off: reverse speeds (ratios of v_max, driven backwards) among the first- and the later-segment commands,
    #: only for a robot that may drive backwards (``robot_config.allow_backwards``; the reference robots may not).
    #: () = never (the default): fewer collisions where nobody yields, but robots backed away from bottleneck
    #: walkers until the time ran out (see the planner history in the docs)
    reverse_speed_ratios: tuple[float, ...] = ()

    @model_validator(mode="after")
    def _ratios_in_range(self) -> SamplingConfig:
        for name in (
            "speed_ratios",
            "near_field_speed_ratios",
            "turn_then_go_speeds",
            "veer_speeds",
            "reverse_speed_ratios",
        ):
            bad = [r for r in getattr(self, name) if not 0.0 <= r <= 1.0]
            if bad:
                raise ValueError(f"{name} must lie in [0, 1] (ratios of the speed limit), got {bad}")
        if any(not -1.0 <= r <= 1.0 for r in self.veer_turn_rates):
            raise ValueError(
                f"veer_turn_rates are ratios of the turn-rate limit in [-1, 1], got {list(self.veer_turn_rates)}"
            )
        if any(d <= 0 for d in self.veer_durations_s):
            raise ValueError(f"veer_durations_s must be positive [s], got {list(self.veer_durations_s)}")
        return self


class SearchConfig(_Frozen):
    """Beam search over piecewise-constant command sequences on the forecast's time grid."""

    segments_s: tuple[float, ...] = (0.8,)  #: durations of segments 1..S-1 [s]; the last lasts to the horizon
    #: extend the forecast at its final velocity [s]: 2.4 + 1.6 s lets the robot clear a walker's path in time
    extra_horizon_s: float = Field(default=1.6, ge=0, le=5)
    beam_width: int = Field(default=6, ge=1, le=64)
    branch_speed_ratios: tuple[float, ...] = (0.0, 0.5, 1.0)  #: later-segment speeds, ratios of max speed
    branch_turn_rate_count: int = Field(default=5, ge=1, le=21)  #: later-segment turn rates over +-w_max
    branch_direction_count: int = Field(
        default=8, ge=4, le=72
    )  #: a holonomic robot's later-segment directions
    #: grid [m] of the route potential's distances around the walls (``geodesic``); 0 = straight lines (grid variant
    #: ``straight_line``): routing around walls solved more episodes; a 0.2 m grid lost bottlenecks (see the planner history in the docs)
    geodesic_resolution: float = Field(default=0.1, ge=0, le=1)
    #: the last decision's sequence, one step on, is a candidate too (receding horizon with a memory): a plan begun,
    #: such as a point turn, can be carried out instead of being replaced by whichever fixed candidate is cheapest
    #: (near-ties flipped the robot between a point turn and driving on, step after step, at a fraction of its speed);
    #: 2-4 % less time to the goal (see the planner history in the docs)
    keep_plan: bool = True
    #: a rollout that reaches the goal earlier counts as that much more progress (v_max x the time it has left), so
    #: the robot does not slow down once every candidate reaches the goal within the horizon (it timed out within
    #: metres of the goal); 5-7 % less time to the goal (see the planner history in the docs)
    arrival_credit: bool = True
    #: a rollout's steps after it reached the goal cost nothing: the episode ends there (as in the simulator), so a
    #: pedestrian or wall the rollout would meet beyond the goal is never met (a robot whose goal lies just past a
    #: door braked for walkers coming through it) (see the planner history in the docs)
    ends_at_goal: bool = True
    adaptive_horizon: bool = False  #: lengthen the horizon by ``horizon_boost_s`` in the near field
    horizon_boost_s: float = Field(default=0.0, ge=0, le=5)

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


class SafetyConfig(_Frozen):
    """Margins [m] added to the true radii; the forecast's spread (sigma) widens them with its age."""

    extra_robot_margin: float = Field(default=0.0, ge=0)  #: added to the robot radius for pedestrians
    extra_ped_margin: float = Field(default=0.0, ge=0)  #: added to the pedestrian radius
    collision_margin: float = Field(default=0.1, ge=0)  #: inside it a step counts as a (predicted) collision
    confidence: float = Field(default=1.0, ge=0, le=4)  #: chance margin in forecast standard deviations
    near_distance: float = Field(default=0.5, ge=0)  #: near-miss band beyond the collision distance
    ttc_distance: float = Field(default=0.4, ge=0)  #: a step inside it ends the time to collision
    hard_clearance_distance: float = Field(default=0.3, ge=0)
    progress_risk_distance: float = Field(default=0.8, ge=0)
    speed_clearance_gain: float = Field(default=0.25, ge=0)  #: extra margin per robot speed [m per m/s]
    static_margin: float = Field(default=0.05, ge=0)  #: hard: rollouts closer to an edge are infeasible
    static_soft_distance: float = Field(default=0.4, ge=0)  #: soft clearance band beyond the hard margin
    discount: float = Field(default=0.9, gt=0, le=1)  #: per forecast step weight of pedestrian terms
    stall_after_s: float = Field(default=2.0, gt=0)  #: window over which route progress is measured [s]
    stall_ramp_s: float = Field(default=3.0, gt=0)  #: time for assertiveness to move between 0 and 1 [s]
    stall_progress: float = Field(default=0.5, gt=0)  #: less route progress [m] in the window is a stall
    stall_margin_relief: float = Field(default=0.5, ge=0, le=1)  #: soft margins dropped at full assertiveness
    #: after a stall, a pedestrian forecast to stand (slower than ``waiting_speed`` [m/s]) is waiting for the robot:
    #: it is expected to make up to this much room [m] x assertiveness (people who walk on never are). Off by
    #: default: it frees doorway deadlocks, but slow walkers taken for waiting ones are run into (see the planner history in the docs)
    waiting_room: float = Field(default=0.0, ge=0)
    waiting_speed: float = Field(default=0.25, ge=0)
    #: a pedestrian walking away from the robot (its forecast velocity points away from the robot) does not walk
    #: into it, so a robot held up behind walkers may pass them closer: their clearance counts this much larger
    #: [m], in full from ``receding_speed`` [m/s] away (linearly less down to 0 m/s), and only while the robot is
    #: slow: in full up to half of ``receding_max_speed`` x v_max, none from it on (a fast robot keeps full margins:
    #: walkers who do not see it turn into it at waypoints). 0 = off (see the planner history in the docs)
    receding_room: float = Field(default=0.5, ge=0)
    receding_speed: float = Field(default=0.3, gt=0)
    receding_max_speed: float = Field(default=0.8, gt=0, le=1)
    #: straight lines: while the robot is slow (below ``straight_max_speed`` x v_max), a pedestrian closing in
    #: on it at this speed [m/s] or more, not yet seen to give way to it, is held to its forecast and to the straight
    #: line of its current velocity, whichever comes nearer (one who does not see the robot walks on into it). Off
    #: by default: 0.3 halves the collisions where nobody yields but costs reacting crowds successes (see the planner history in the docs)
    straight_speed: float = Field(default=0.0, ge=0)
    straight_max_speed: float = Field(default=0.4, gt=0, le=1)
    #: yield, then commit: after a stall (assertiveness 0.8) a pedestrian standing (slower than ``waiting_speed``)
    #: near the robot is taken to wait for it: to stay put and step away from it at up to this [m/s] as it edges
    #: forward, until seen to hold its ground (within ``yield_range`` + 0.3 m of contact for ``yield_test_s``
    #: while the robot closed in, it did not move). Walking pedestrians never are (many never see the robot).
    #: 0: nobody is; it ends doorway standoffs (see the planner history in the docs)
    yield_speed: float = Field(default=0.3, ge=0)
    #: lingering: a pedestrian within ``yield_range`` of contact now and ``standing_stays_s`` [s] ago, who moved less than
    #: 0.5 m in between, is forecast on its own velocity (standing, shuffling), not on the model's forecast, which for
    #: people by the robot has them walk off (the model learned from people who make room). 0 = off (grid variant
    #: ``no_lingering``) (see the planner history in the docs)
    standing_stays_s: float = Field(default=1.5, ge=0)
    yield_range: float = Field(default=1.2, ge=0)  #: ... starting this far beyond contact [m]
    yield_test_s: float = Field(
        default=3.0, gt=0
    )  #: [s]; long enough for reacting people, who step back slowly
    static_field_resolution: float = Field(default=0.1, ge=0, le=0.5)  #: [m]; 0 = exact distance queries
    lane_memory_s: float = Field(
        default=20.0, gt=0
    )  #: how long a walker's pass is remembered (decay time) [s]


class WeightsConfig(_Frozen):
    """Cost weights (lower cost is better); see ``core.planners.predictive.cost`` for the terms."""

    goal: float = Field(default=6.0, ge=0)  #: per metre of route progress
    collision: float = Field(default=60.0, ge=0)
    risk: float = Field(default=80.0, ge=0)  #: per expected contact step (probability summed over steps)
    near_miss: float = Field(default=2.0, ge=0)
    ttc: float = Field(default=6.0, ge=0)
    progress_risk: float = Field(default=3.0, ge=0)
    hard_clearance: float = Field(default=20.0, ge=0)
    static: float = Field(default=3.0, ge=0)  #: soft static clearance
    static_collision: float = Field(default=1000.0, ge=0)  #: per infeasible (too close to an edge) step
    velocity: float = Field(default=0.0, ge=0)
    turn: float = Field(default=0.1, ge=0)
    smoothness: float = Field(default=0.3, ge=0)  #: change of the first command from the last one
    heading: float = Field(default=1.0, ge=0)  #: mean heading error to the active waypoint over the horizon
    lane: float = Field(
        default=2.0, ge=0
    )  #: per walker lately through where a rollout ends at rest (``traffic``)


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
                raise ConfigError(
                    f"reference planner key {key!r} has no mapping (mapped keys: {', '.join(sorted(REFERENCE_KEY_MAP))})",
                    source=source,
                    item=key,
                )
            section, field, kind, ref_value = rule
            target = data[section] if section else data
            target[field] = _map_value(key, value, kind, ref_value, target[field], source)
        return cls.from_dict(data, source=source)


#: Reference rollout time over which a heading delta is taken as a turn rate [s]. The reference divided by
#: its 0.2 s rollout step, so every delta >= 0.24 rad saturated (three distinct rates, pipeline notes §3.3);
#: we read a delta as the heading change over one second, which keeps the deltas distinct.
HEADING_DELTA_TIME_S = 1.0
#: Reference rollout step [s]: its horizon boost was counted in these steps.
REFERENCE_ROLLOUT_DT = 0.2

# key -> (section, field, kind, reference camera-ready value)
# kinds: "ratio"  ours = our default * value / reference value (keeps our scale, moves emphasis alike);
#        "delta"  ours = our default + (value - reference value) (distances: shift our margins alike), >= 0;
#        "margin" extra safety margin = max(0, value - reference value) (radius keys; true radii always apply);
#        "same"   taken as is (dimensionless ratios / gains / flags with the same meaning);
#        "turn"   heading deltas [rad] -> turn rates delta / HEADING_DELTA_TIME_S [rad/s];
#        "steps"  reference rollout steps -> seconds.
REFERENCE_KEY_MAP: dict[str, tuple[str | None, str, str, float | None]] = {
    "predictive_goal_weight": ("weights", "goal", "ratio", 6.0),
    "predictive_collision_weight": ("weights", "collision", "ratio", 0.5),
    "predictive_near_miss_weight": ("weights", "near_miss", "ratio", 0.10),
    "predictive_ttc_weight": ("weights", "ttc", "ratio", 0.30),
    "predictive_progress_risk_weight": ("weights", "progress_risk", "ratio", 2.2),
    "predictive_hard_clearance_weight": ("weights", "hard_clearance", "ratio", 3.0),
    "predictive_velocity_weight": ("weights", "velocity", "ratio", 0.01),
    "predictive_turn_weight": ("weights", "turn", "ratio", 0.01),
    # the reference meant its occupancy term for static obstacles (it read the pedestrian channel by mistake)
    "occupancy_weight": ("weights", "static", "ratio", 0.25),
    "predictive_ttc_distance": ("safety", "ttc_distance", "delta", 0.9),
    "predictive_progress_risk_distance": ("safety", "progress_risk_distance", "delta", 1.3),
    "predictive_hard_clearance_distance": ("safety", "hard_clearance_distance", "delta", 0.8),
    "predictive_safe_distance": ("safety", "collision_margin", "delta", 0.35),
    "predictive_near_distance": ("safety", "near_distance", "delta", 0.7),
    "predictive_robot_radius": ("safety", "extra_robot_margin", "margin", 0.25),
    "predictive_pedestrian_radius": ("safety", "extra_ped_margin", "margin", 0.25),
    "predictive_speed_clearance_gain": ("safety", "speed_clearance_gain", "same", None),
    "predictive_candidate_speeds": ("sampling", "speed_ratios", "same", None),
    "predictive_candidate_heading_deltas": ("sampling", "turn_rates", "turn", None),
    "predictive_near_field_distance": ("sampling", "near_field_distance", "delta", 2.6),
    "predictive_near_field_speed_cap": ("sampling", "near_field_speed_cap", "same", None),
    "predictive_near_field_speed_samples": ("sampling", "near_field_speed_ratios", "same", None),
    "predictive_near_field_heading_deltas": ("sampling", "near_field_turn_rates", "turn", None),
    "predictive_adaptive_horizon_enabled": ("search", "adaptive_horizon", "same", None),
    "predictive_horizon_boost_steps": ("search", "horizon_boost_s", "steps", None),
    "predictive_beam_width": ("search", "beam_width", "same", None),
}


def _map_value(key: str, value: Any, kind: str, ref: float | None, ours: Any, source: str | None) -> Any:
    """Translate one reference value into our field's value (see the kinds above)."""
    try:
        if kind == "same":
            return tuple(float(v) for v in value) if isinstance(value, list | tuple) else value
        if kind == "turn":
            return tuple(float(d) / HEADING_DELTA_TIME_S for d in value)
        if kind == "steps":
            return float(value) * REFERENCE_ROLLOUT_DT
        v = float(value)
        if not math.isfinite(v):
            raise ValueError("not finite")
        if kind == "ratio":
            return float(ours) * v / float(ref)
        if kind == "delta":
            return max(0.0, float(ours) + v - float(ref))
        if kind == "margin":
            return max(0.0, v - float(ref))
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"cannot map value {value!r}: {exc}", source=source, item=key) from None
    raise AssertionError(f"unknown mapping kind {kind!r}")
