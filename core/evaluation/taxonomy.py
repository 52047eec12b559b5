"""Failure taxonomy by mechanism: one primary label per failed episode, plus tags.

Labels and default thresholds are those of the shared metrics-and-taxonomy.md; the thresholds live in
:class:`TaxonomyConfig`, which every evaluation reports next to its taxonomy counts so that two
taxonomies are only compared under the same definitions.

A pedestrian collision is the planner's (``collision_pedestrian_robot_fault``) when the robot drove into
the pedestrian (approach speed at contact above ``robot_fault_approach_speed``) or when an admissible
robot motion from the moment the conflict became visible would have avoided it
(``core.evaluation.escape``); only an unavoidable contact is ``collision_pedestrian_pedestrian_fault``.
Standing still in the path of a pedestrian seen for seconds is therefore the robot's fault.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from foresight.core.evaluation.escape import escape_exists
from foresight.core.evaluation.metrics import (
    Derived,
    no_progress_mask,
    sign_change_steps,
    time_to_collision,
    window_steps,
)
from foresight.core.sim.observation import StaticGeometry
from foresight.core.sim.robot import RobotLimits

Label = Literal[
    "collision_pedestrian_robot_fault",
    "collision_pedestrian_pedestrian_fault",
    "collision_static",
    "out_of_bounds",
    "timeout_freeze",
    "timeout_oscillation",
    "timeout_slow_progress",
    "planner_error",
]
LABELS: tuple[str, ...] = Label.__args__  # type: ignore[attr-defined]
Tag = Literal["near_miss", "late_reaction", "prediction_miss", "deadlock"]


class TaxonomyConfig(BaseModel):
    """Thresholds of the taxonomy (defaults: metrics-and-taxonomy.md)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    robot_fault_approach_speed: float = Field(
        default=0.2, ge=0
    )  #: robot speed toward the ped at contact above this = robot fault [m/s]
    stopped_speed: float = Field(default=0.05, ge=0)  #: nearly stopped below this [m/s]
    freeze_min_s: float = Field(default=3.0, gt=0)  #: total nearly-stopped time with a ped near [s]
    freeze_ped_distance: float = Field(
        default=3.0, gt=0
    )  #: "pedestrian near": centre distance within this [m]
    oscillation_min_sign_changes: int = Field(
        default=4, ge=1, le=1000
    )  #: sign changes of omega within the window
    oscillation_omega_min: float = Field(
        default=0.2, ge=0
    )  #: only samples with |omega| above this count [rad/s]
    oscillation_window_s: float = Field(default=5.0, gt=0)  #: [s]
    oscillation_max_progress: float = Field(
        default=0.5, ge=0
    )  #: net route progress in the window below this [m]
    near_miss_clearance: float = Field(default=0.5, gt=0)  #: surface clearance in [0, this) [m]
    late_reaction_ttc_s: float = Field(default=1.0, gt=0)  #: TTC when avoidance began below this = late [s]
    reaction_lookback_s: float = Field(default=10.0, gt=0)  #: how far back avoidance is searched [s]
    reaction_min_decrease: float = Field(
        default=0.05, ge=0
    )  #: approach-speed drop that counts as avoiding [m/s]
    deadlock_progress: float = Field(default=0.05, ge=0)  #: route progress at most this ... [m]
    deadlock_window_s: float = Field(default=1.5, gt=0)  #: ... over this window = deadlock [s]
    prediction_miss_error: float = Field(
        default=1.0, gt=0
    )  #: mean predictor error on the involved ped above this [m]
    fault_lookback_s: float = Field(
        default=3.0, gt=0
    )  #: the conflict is visible at most this long before contact [s]
    fault_extension_s: float = Field(
        default=1.0, ge=0
    )  #: an escape must stay clear this long past the contact [s]
    #: failed episodes where nobody reacts to the robot: could any robot have reached the goal? (``reachable``;
    #: core.sim.feasibility, about 0.5 s per failed episode)
    check_reachability: bool = True


class TaxonomyResult(BaseModel):
    label: Label | None  #: None for successes
    tags: list[Tag] = Field(default_factory=list)
    critical_ped_id: int | None = None  #: the pedestrian involved (collision, or closest approach)
    critical_step: int | None = None
    avoidable: bool | None = (
        None  #: pedestrian collisions: an admissible motion from the decision step avoids it
    )
    decision_step: int | None = None  #: pedestrian collisions: the state the escape check starts from
    #: failures where nobody reacts to the robot: False = no robot could have reached the goal in time (the episode
    #: measures no planner), True = one could; None: not checked (a success, or pedestrians who react to the robot)
    reachable: bool | None = None


def _critical(d: Derived, step: int | None) -> tuple[int, int] | None:
    """(state index, slot) of the collision step's nearest pedestrian, else of the closest approach."""
    if not np.isfinite(d.nearest).any():
        return None
    t = int(step) if step is not None else int(np.argmin(d.nearest))
    t = min(max(t, 0), d.steps)
    if not np.isfinite(d.dist[t]).any():
        return None
    return t, int(np.argmin(d.dist[t]))


def approach_speed(d: Derived, t: int, slot: int) -> float:
    """Robot speed along the line of centres toward the pedestrian at state ``t`` (positive = closing) [m/s].

    Uses the displacement into state ``t`` (what actually produced the contact), the state velocity at t=0.
    """
    vel = (d.pos[t] - d.pos[t - 1]) / d.dt if t > 0 else d.vel[0]
    los = d.ped_pos[t, slot] - d.pos[t]
    n = np.linalg.norm(los)
    return float(vel @ los / n) if n > 1e-9 else 0.0


def _avoidance_start(d: Derived, t: int, slot: int, cfg: TaxonomyConfig) -> int:
    """State where the robot began avoiding the event at ``t`` (``t`` if it never did).

    Avoiding = the robot's own velocity change reduces its speed toward the pedestrian (braking or
    turning away); changes of the line of sight caused by the pedestrian do not count. The final
    stretch before ``t`` without any increase is taken, and avoidance began at its first reduction.
    """
    pid = d.ped_ids[t, slot]
    first = max(0, t - window_steps(cfg.reaction_lookback_s, d.dt))
    same = d.ped_ids[first : t + 1, slot] == pid
    first = first + int(np.flatnonzero(same)[0]) if same.any() else t
    los = d.ped_pos[first : t + 1, slot] - d.pos[first : t + 1]
    unit = los / np.maximum(np.linalg.norm(los, axis=1, keepdims=True), 1e-9)
    proj = np.einsum(
        "ti,ti->t", np.diff(d.vel[first : t + 1], axis=0), unit[:-1]
    )  # own approach change per step
    eps = 1e-9
    k = proj.size
    while k > 0 and proj[k - 1] <= eps:
        k -= 1
    tail = proj[k:]
    reducing = np.flatnonzero(tail < -eps)
    if reducing.size == 0 or -tail[reducing].sum() < cfg.reaction_min_decrease:
        return t
    return first + k + int(reducing[0])


def decision_step(d: Derived, t: int, slot: int, cfg: TaxonomyConfig) -> int:
    """The state at which the conflict with the pedestrian in ``slot`` at ``t`` became visible: its first
    recorded step in that slot (spawn), but at most ``fault_lookback_s`` before ``t``."""
    first = max(0, t - window_steps(cfg.fault_lookback_s, d.dt))
    same = d.ped_ids[first : t + 1, slot] == d.ped_ids[t, slot]
    k = int(np.argmin(same[::-1])) if not same.all() else same.size  # trailing run of the same id
    return t - k + 1 if k < same.size else first


def _late_reaction(d: Derived, t: int, slot: int, cfg: TaxonomyConfig, radius: float) -> bool:
    s = _avoidance_start(d, t, slot, cfg)
    rel = d.ped_pos[s, slot] - d.pos[s]
    ttc = float(time_to_collision(rel, d.ped_vel[s, slot] - d.vel[s], radius))
    return ttc < cfg.late_reaction_ttc_s


def _freeze_time(d: Derived, cfg: TaxonomyConfig) -> float:
    frozen = (d.speed < cfg.stopped_speed) & (d.nearest <= cfg.freeze_ped_distance)
    return float(frozen[1:].sum() * d.dt)


def _oscillating(d: Derived, cfg: TaxonomyConfig) -> bool:
    changes = sign_change_steps(d.omega, cfg.oscillation_omega_min)
    k = cfg.oscillation_min_sign_changes
    w = window_steps(cfg.oscillation_window_s, d.dt)
    for i in range(changes.size - k + 1):
        start, last = int(changes[i]), int(changes[i + k - 1])
        if last - start > w:
            continue
        begin = max(0, last - w)  # a window of w steps ending at the k-th flip holds all k flips
        if d.progress[last] - d.progress[begin] < cfg.oscillation_max_progress:
            return True
    return False


def _primary(
    outcome: str,
    collision_kind: str | None,
    d: Derived,
    crit: tuple[int, int] | None,
    cfg: TaxonomyConfig,
    avoidable: bool | None,
) -> Label | None:
    if outcome == "success":
        return None
    if outcome == "error":
        return "planner_error"
    if outcome == "collision_pedestrian":
        if crit is None or avoidable or approach_speed(d, *crit) > cfg.robot_fault_approach_speed:
            return "collision_pedestrian_robot_fault"
        return "collision_pedestrian_pedestrian_fault"
    if outcome == "collision_static":
        return "out_of_bounds" if collision_kind == "out_of_bounds" else "collision_static"
    if _freeze_time(d, cfg) >= cfg.freeze_min_s:
        return "timeout_freeze"
    if _oscillating(d, cfg):
        return "timeout_oscillation"
    return "timeout_slow_progress"


def classify(
    d: Derived,
    outcome: str,
    *,
    robot_radius: float,
    ped_radius: float,
    collision_kind: str | None = None,
    collision_step: int | None = None,
    prediction_error: dict[int, float] | None = None,
    cfg: TaxonomyConfig | None = None,
    limits: RobotLimits | None = None,
    static: StaticGeometry | None = None,
) -> TaxonomyResult:
    """Primary label (failed episodes) and tags (any episode) of one episode.

    ``prediction_error`` maps pedestrian id -> mean predictor displacement error [m] over the episode,
    when the planner reported its predictions. ``limits`` (default: the reference robot) and ``static``
    (the map, when known) bound the motions the escape check of a pedestrian collision may try.
    """
    cfg = cfg or TaxonomyConfig()
    ped_event = outcome == "collision_pedestrian"
    crit = _critical(d, collision_step if ped_event else None)
    start = avoidable = None
    if ped_event and crit is not None:
        start = decision_step(d, *crit, cfg)
        avoidable = escape_exists(
            d.robot,
            d.ped_ids,
            d.ped_pos,
            d.ped_vel,
            start=start,
            contact=crit[0],
            dt=d.dt,
            limits=limits or RobotLimits(),
            robot_radius=robot_radius,
            ped_radius=ped_radius,
            extension_steps=int(round(cfg.fault_extension_s / d.dt)),
            static=static,
        )
    label = _primary(outcome, collision_kind, d, crit, cfg, avoidable)
    tags: list[Tag] = []
    near = (d.clearance >= 0) & (d.clearance < cfg.near_miss_clearance)
    if near.any():
        tags.append("near_miss")
    close_call = crit is not None and (ped_event or d.clearance[crit[0]] < cfg.near_miss_clearance)
    if close_call and _late_reaction(d, crit[0], crit[1], cfg, robot_radius + ped_radius):
        tags.append("late_reaction")
    pid = int(d.ped_ids[crit]) if crit is not None else None
    if close_call and prediction_error and prediction_error.get(pid, 0.0) > cfg.prediction_miss_error:
        tags.append("prediction_miss")
    if label is not None and no_progress_mask(d, cfg.deadlock_window_s, cfg.deadlock_progress).any():
        tags.append("deadlock")
    return TaxonomyResult(
        label=label,
        tags=tags,
        critical_ped_id=pid if close_call else None,
        critical_step=crit[0] if close_call else None,
        avoidable=avoidable,
        decision_step=start,
    )


def count_labels(labels: list[str | None]) -> dict[str, int]:
    """Counts of every label (zeros included, so two taxonomies always have the same keys)."""
    counts = dict.fromkeys(LABELS, 0)
    for lab in labels:
        if lab is not None:
            counts[lab] += 1
    return counts
