"""Keys of the predictive planner's config written elsewhere: the flat keys of before the settings were nested
(stored job specs, recorded resolved configs, old command lines), and the reference planner grid's keys.

Both are read, never written: ``config.PredictivePlannerConfig`` moves an old key to its place before
validation and maps a reference grid variant's ``params`` onto its own fields.
"""

from __future__ import annotations

import math
from typing import Any

from foresight.core.errors import ConfigError

#: section -> old flat key -> its path in the section now. A key not here is validated as written (an unknown
#: one is an error naming it); ``weights.static`` moves only when it is a number (it is a group now).
OLD_KEYS: dict[str, dict[str, tuple[str, ...]]] = {
    "sampling": {
        "near_field_distance": ("near_field", "distance"),
        "near_field_turn_rate_count": ("near_field", "turn_rate_count"),
        "near_field_turn_rates": ("near_field", "turn_rates"),
        "near_field_speed_ratios": ("near_field", "speed_ratios"),
        "near_field_speed_cap": ("near_field", "speed_cap"),
        "near_field_direction_count": ("near_field", "direction_count"),
        "turn_then_go": ("point_turns", "angles"),
        "turn_then_go_speeds": ("point_turns", "speed_ratios"),
        "veer_turn_rates": ("veers", "turn_rates"),
        "veer_speeds": ("veers", "speed_ratios"),
        "veer_durations_s": ("veers", "durations_s"),
    },
    "safety": {
        **{
            key: ("pedestrians", key)
            for key in (
                "extra_robot_margin",
                "extra_ped_margin",
                "collision_margin",
                "confidence",
                "near_distance",
                "ttc_distance",
                "hard_clearance_distance",
                "progress_risk_distance",
                "speed_clearance_gain",
                "discount",
            )
        },
        "static_margin": ("static", "margin"),
        "static_soft_distance": ("static", "soft_distance"),
        "static_field_resolution": ("static", "field_resolution"),
        "stall_after_s": ("stall", "after_s"),
        "stall_ramp_s": ("stall", "ramp_s"),
        "stall_progress": ("stall", "progress"),
        "stall_margin_relief": ("stall", "margin_relief"),
        "waiting_speed": ("crowd", "standing_speed"),
        "yield_range": ("crowd", "beside_distance"),
        "standing_stays_s": ("crowd", "lingering_s"),
        "waiting_room": ("crowd", "waiting_room"),
        "lane_memory_s": ("crowd", "lane_memory_s"),
        "yield_speed": ("crowd", "yielding", "speed"),
        "yield_test_s": ("crowd", "yielding", "test_s"),
        "receding_room": ("crowd", "receding", "room"),
        "receding_speed": ("crowd", "receding", "speed"),
        "receding_max_speed": ("crowd", "receding", "max_robot_speed"),
        "straight_speed": ("crowd", "straight", "speed"),
        "straight_max_speed": ("crowd", "straight", "max_robot_speed"),
    },
    "weights": {
        **{
            key: ("pedestrians", key)
            for key in ("collision", "risk", "near_miss", "ttc", "progress_risk", "hard_clearance")
        },
        "static": ("static", "clearance"),
        "static_collision": ("static", "collision"),
        **{key: ("motion", key) for key in ("velocity", "turn", "smoothness")},
    },
}


def move_old_keys(data: Any, moved: dict[str, tuple[str, ...]], fields: set[str]) -> Any:
    """``data`` (one section's dict) with each old flat key moved to its nested path; the same setting given
    both ways is an error naming both."""
    if not isinstance(data, dict):
        return data
    old = [k for k in moved if k in data and not (k in fields and _is_group(data[k]))]
    if not old:
        return data
    out = dict(data)
    for key in old:
        value, node = out.pop(key), out
        *groups, name = moved[key]
        for group in groups:
            sub = node.get(group, {})
            if hasattr(sub, "model_dump"):  # a section given as a model: only what was set counts as given
                sub = sub.model_dump(exclude_unset=True)
            if not isinstance(sub, dict):
                raise ValueError(f"{group!r} must be a mapping (it holds {key!r} now)")
            node[group] = dict(sub)
            node = node[group]
        if name in node:
            raise ValueError(f"{key!r} is the old name of {'.'.join(moved[key])!r}: give one of them")
        node[name] = value
    return out


def _is_group(value: Any) -> bool:
    return isinstance(value, dict) or hasattr(value, "model_dump")


#: Reference rollout time over which a heading delta is taken as a turn rate [s]. The reference divided by
#: its 0.2 s rollout step, so every delta >= 0.24 rad saturated (three distinct rates, pipeline notes §3.3);
#: we read a delta as the heading change over one second, which keeps the deltas distinct.
HEADING_DELTA_TIME_S = 1.0
#: Reference rollout step [s]: its horizon boost was counted in these steps.
REFERENCE_ROLLOUT_DT = 0.2

# key -> (our dotted path, kind, reference camera-ready value)
# kinds: "ratio"  ours = our default * value / reference value (keeps our scale, moves emphasis alike);
#        "delta"  ours = our default + (value - reference value) (distances: shift our margins alike), >= 0;
#        "margin" extra safety margin = max(0, value - reference value) (radius keys; true radii apply);
#        "same"   taken as is (dimensionless ratios / gains / flags with the same meaning);
#        "turn"   heading deltas [rad] -> turn rates delta / HEADING_DELTA_TIME_S [rad/s];
#        "steps"  reference rollout steps -> seconds.
REFERENCE_KEY_MAP: dict[str, tuple[str, str, float | None]] = {
    "predictive_goal_weight": ("weights.goal", "ratio", 6.0),
    "predictive_collision_weight": ("weights.pedestrians.collision", "ratio", 0.5),
    "predictive_near_miss_weight": ("weights.pedestrians.near_miss", "ratio", 0.10),
    "predictive_ttc_weight": ("weights.pedestrians.ttc", "ratio", 0.30),
    "predictive_progress_risk_weight": ("weights.pedestrians.progress_risk", "ratio", 2.2),
    "predictive_hard_clearance_weight": ("weights.pedestrians.hard_clearance", "ratio", 3.0),
    "predictive_velocity_weight": ("weights.motion.velocity", "ratio", 0.01),
    "predictive_turn_weight": ("weights.motion.turn", "ratio", 0.01),
    # the reference meant its occupancy term for static obstacles (it read the pedestrian channel by mistake)
    "occupancy_weight": ("weights.static.clearance", "ratio", 0.25),
    "predictive_ttc_distance": ("safety.pedestrians.ttc_distance", "delta", 0.9),
    "predictive_progress_risk_distance": ("safety.pedestrians.progress_risk_distance", "delta", 1.3),
    "predictive_hard_clearance_distance": ("safety.pedestrians.hard_clearance_distance", "delta", 0.8),
    "predictive_safe_distance": ("safety.pedestrians.collision_margin", "delta", 0.35),
    "predictive_near_distance": ("safety.pedestrians.near_distance", "delta", 0.7),
    "predictive_robot_radius": ("safety.pedestrians.extra_robot_margin", "margin", 0.25),
    "predictive_pedestrian_radius": ("safety.pedestrians.extra_ped_margin", "margin", 0.25),
    "predictive_speed_clearance_gain": ("safety.pedestrians.speed_clearance_gain", "same", None),
    "predictive_candidate_speeds": ("sampling.speed_ratios", "same", None),
    "predictive_candidate_heading_deltas": ("sampling.turn_rates", "turn", None),
    "predictive_near_field_distance": ("sampling.near_field.distance", "delta", 2.6),
    "predictive_near_field_speed_cap": ("sampling.near_field.speed_cap", "same", None),
    "predictive_near_field_speed_samples": ("sampling.near_field.speed_ratios", "same", None),
    "predictive_near_field_heading_deltas": ("sampling.near_field.turn_rates", "turn", None),
    "predictive_adaptive_horizon_enabled": ("search.adaptive_horizon", "same", None),
    "predictive_horizon_boost_steps": ("search.horizon_boost_s", "steps", None),
    "predictive_beam_width": ("search.beam_width", "same", None),
}


def map_reference_value(
    key: str, value: Any, kind: str, ref: float | None, ours: Any, source: str | None
) -> Any:
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
