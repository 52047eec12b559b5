"""Hand-built traces for the evaluation tests: the same arrays a simulator Trace holds, chosen so that
every metric and taxonomy label has a known answer."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from foresight.core.evaluation.metrics import EpisodeGeometry

DT = 0.1
R_ROBOT = 0.3
R_PED = 0.3


@dataclass
class FakeTrace:
    robot: np.ndarray
    command: np.ndarray
    ped_ids: np.ndarray
    ped_pos: np.ndarray
    ped_vel: np.ndarray
    dt: float = DT


def _forward_speed(xy: np.ndarray, dt: float) -> np.ndarray:
    step = np.linalg.norm(np.diff(xy, axis=0), axis=1) / dt
    return np.concatenate([step, step[-1:]]) if step.size else np.zeros(1)


def make_trace(xy, peds=(), *, v=None, heading=None, omega=None, ped_ids=None, dt: float = DT) -> FakeTrace:
    """Robot positions (T+1, 2) and pedestrian tracks [(T+1, 2), ...]; v/heading default to the motion."""
    xy = np.asarray(xy, dtype=float)
    n = xy.shape[0]
    if heading is None:
        d = np.diff(xy, axis=0)
        h = np.arctan2(d[:, 1], d[:, 0]) if d.size else np.zeros(0)
        heading = np.concatenate([h, h[-1:]]) if h.size else np.zeros(1)
    v = _forward_speed(xy, dt) if v is None else np.broadcast_to(np.asarray(v, float), (n,))
    omega = np.zeros(n) if omega is None else np.broadcast_to(np.asarray(omega, float), (n,))
    robot = np.column_stack([xy, heading, v, omega])
    tracks = [np.asarray(p, dtype=float) for p in peds]
    ped_pos = np.stack(tracks, axis=1) if tracks else np.zeros((n, 0, 2))
    ped_vel = np.zeros_like(ped_pos)
    if tracks:
        ped_vel[:-1] = np.diff(ped_pos, axis=0) / dt
        ped_vel[-1] = ped_vel[-2] if n > 1 else 0.0
    ids = np.tile(np.arange(len(tracks), dtype=np.int64), (n, 1)) if ped_ids is None else np.asarray(ped_ids)
    return FakeTrace(
        robot=robot, command=robot[:-1, 3:5].copy(), ped_ids=ids, ped_pos=ped_pos, ped_vel=ped_vel, dt=dt
    )


def straight(x0: float, speed: float, steps: int, y: float = 0.0) -> np.ndarray:
    """Positions of a constant-speed walk along +x (steps + 1 states)."""
    x = x0 + speed * DT * np.arange(steps + 1)
    return np.column_stack([x, np.full(steps + 1, y)])


def still(p, steps: int) -> np.ndarray:
    return np.tile(np.asarray(p, dtype=float), (steps + 1, 1))


def geometry(goal=(100.0, 0.0), horizon: int = 1000, tol: float = 0.0) -> EpisodeGeometry:
    return EpisodeGeometry(
        robot_radius=R_ROBOT,
        ped_radius=R_PED,
        horizon=horizon,
        route=np.asarray([goal], dtype=float),
        goal_tolerance=tol,
    )


def braking(x_brake: float, stop_x: float, ped_x: float, hold_steps: int = 20) -> FakeTrace:
    """Robot at 1 m/s along +x, braking uniformly from x_brake to a stop at stop_x, then holding."""
    a = 1.0 / (2.0 * (stop_x - x_brake))
    xs, vs, x, v = [0.0], [1.0], 0.0, 1.0
    while x < x_brake - 1e-9:
        x += v * DT
        xs.append(x)
        vs.append(v)
    while v > 1e-9:
        v_next = max(0.0, v - a * DT)
        x += 0.5 * (v + v_next) * DT
        v = v_next
        xs.append(x)
        vs.append(v)
    xs += [x] * hold_steps
    vs += [0.0] * hold_steps
    xy = np.column_stack([xs, np.zeros(len(xs))])
    return make_trace(xy, [still((ped_x, 0.0), len(xs) - 1)], v=np.asarray(vs), heading=np.zeros(len(xs)))


def provenance(scenario: str = "s_low", seed: int = 0, **kw):
    from foresight.core.evaluation.record import Provenance

    base = dict(
        scenario=scenario,
        archetype=scenario.rsplit("_", 1)[0],
        density=scenario.rsplit("_", 1)[-1],
        seed=seed,
        planner="predictive",
        planner_config_hash="abc123",
        model_id="cv",
        checkpoint_sha256="cv",
        code_version="0.1.0+test",
        dt=DT,
        horizon=1000,
    )
    base.update(kw)
    return Provenance(**base)


def record(
    scenario: str = "s_low",
    seed: int = 0,
    outcome: str = "success",
    *,
    ped_y: float = 2.0,
    speed: float = 1.0,
    **prov,
):
    """A record of a straight 10 m run past a standing pedestrian ``ped_y`` metres off the path."""
    from foresight.core.evaluation.record import build_record

    steps = int(round(10.0 / speed / DT))
    if outcome == "collision_pedestrian":  # stop at contact: centre distance = radii
        gap = np.sqrt(max((R_ROBOT + R_PED) ** 2 - ped_y**2, 0.0))
        steps = int(np.ceil((5.0 - gap) / speed / DT - 1e-9))
    tr = make_trace(straight(0.0, speed, steps), [still((5.0, ped_y), steps)])
    kind = {"collision_pedestrian": "pedestrian", "collision_static": "static"}.get(outcome)
    return build_record(
        tr,
        geometry(goal=(10.0, 0.0)),
        outcome=outcome,
        provenance=provenance(scenario, seed, **prov),
        collision_kind=kind,
        collision_step=steps if kind else None,
        plan_ms=[1.0, 2.0, 3.0],
    )
