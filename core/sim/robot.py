"""Robot kinematics (pure and vectorised) and the robot's route: spawn, goal, waypoints (reference §2).

``unicycle_step`` is the single implementation of the robot's motion: the simulator calls it on a
(5,) state, and the predictive planner imports it to roll out thousands of candidates (..., 5) with
exactly the simulator's kinematics. Keep its name and signature stable.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from core.scenarios.model import RobotConfig

X, Y, TH, V, W = range(5)  #: columns of a robot state (..., 5): x [m], y [m], heading [rad], v [m/s], omega [rad/s]


@dataclass(frozen=True)
class RobotLimits:
    """Speed and acceleration limits plus the actuation model.

    ``actuation``: ``tracking`` = the command (v, omega) is a target reached as fast as the
    acceleration limits allow; ``reference_lag`` = the reference benchmark's behaviour, where the
    runner sends (v_cmd - v, omega_cmd - omega) as an acceleration, so the realised change per step is
    dt * clip(cmd - v, -decel, accel): a first-order lag (time constant 1 s, at most 0.1 m/s per
    0.1 s step).
    ``kind`` ``holonomic``: the command is a world-frame velocity (vx, vy) instead (see ``holonomic_step``).
    """

    radius: float = 1.0  #: [m]
    v_max: float = 2.0  #: [m/s]
    v_min: float = 0.0  #: [m/s]; -v_max when backwards driving is allowed
    w_max: float = 1.0  #: [rad/s]
    accel: float = 1.0  #: [m/s^2]
    decel: float = 1.0  #: [m/s^2]
    alpha: float = 1.0  #: angular acceleration limit [rad/s^2]
    actuation: str = "tracking"
    kind: str = "differential_drive"

    @classmethod
    def from_config(cls, cfg: RobotConfig) -> RobotLimits:
        return cls(
            radius=cfg.radius, v_max=cfg.max_linear_speed, v_min=-cfg.max_linear_speed if cfg.allow_backwards else 0.0,
            w_max=cfg.max_angular_speed, accel=cfg.max_linear_accel, decel=cfg.decel, alpha=cfg.max_angular_accel,
            actuation=cfg.actuation, kind=cfg.type,
        )

    def as_dict(self) -> dict[str, float]:
        """Numeric limits for ``Observation.robot_limits``; ``holonomic`` 1.0 means commands are (vx, vy)."""
        out = {k: v for k, v in asdict(self).items() if isinstance(v, float)}
        out["holonomic"] = 1.0 if self.kind == "holonomic" else 0.0
        return out


def wrap_angle(a: np.ndarray | float) -> np.ndarray | float:
    """Angle(s) wrapped to [-pi, pi) [rad]."""
    return (a + np.pi) % (2 * np.pi) - np.pi


def _clip(a, lo: float, hi: float):
    """np.clip without its Python-level dispatch overhead (matters for the single robot state)."""
    return np.minimum(np.maximum(a, lo), hi)


def unicycle_step(state: np.ndarray, cmd: np.ndarray, limits: RobotLimits, dt: float) -> np.ndarray:
    """Advance differential-drive states (..., 5) under commands (..., 2) = (v, omega) by dt; returns new (..., 5).

    Speeds follow the actuation model within the acceleration limits and are clipped to
    [v_min, v_max] x [-w_max, w_max]; the pose uses the reference's midpoint odometry:
    distance ((v + v') / 2) dt along the mean of the old and new heading. Heading is wrapped.
    Broadcasts over any batch shape; no Python loop, no in-place change of the inputs.
    """
    state = np.asarray(state, dtype=float)
    cmd = np.asarray(cmd, dtype=float)
    if state.ndim == 1 and cmd.ndim == 1:
        return _unicycle_one(state, cmd, limits, dt)
    v, w = state[..., V], state[..., W]
    if limits.actuation == "reference_lag":
        dv = dt * _clip(cmd[..., 0] - v, -limits.decel, limits.accel)
        dw = dt * _clip(cmd[..., 1] - w, -limits.alpha, limits.alpha)
    else:
        dv = _clip(_clip(cmd[..., 0], limits.v_min, limits.v_max) - v, -limits.decel * dt, limits.accel * dt)
        dw = _clip(_clip(cmd[..., 1], -limits.w_max, limits.w_max) - w, -limits.alpha * dt, limits.alpha * dt)
    v2 = _clip(v + dv, limits.v_min, limits.v_max)
    w2 = _clip(w + dw, -limits.w_max, limits.w_max)
    th = state[..., TH]
    th2 = th + 0.5 * (w + w2) * dt
    mid = 0.5 * (th + th2)
    dist = 0.5 * (v + v2) * dt
    out = np.empty(state.shape if state.shape[:-1] == cmd.shape[:-1] else np.broadcast_shapes(state.shape, cmd.shape[:-1] + (5,)))
    out[..., X] = state[..., X] + dist * np.cos(mid)
    out[..., Y] = state[..., Y] + dist * np.sin(mid)
    out[..., TH] = wrap_angle(th2)
    out[..., V] = v2
    out[..., W] = w2
    return out


def _unicycle_one(state: np.ndarray, cmd: np.ndarray, limits: RobotLimits, dt: float) -> np.ndarray:
    """``unicycle_step`` for one (5,) state in Python floats: the same IEEE operations in the same order
    (numpy's cos/sin on scalars use the array loops), ~10x faster than 0-d array arithmetic."""
    x, y, th, v, w = (float(c) for c in state)
    cv, cw = float(cmd[0]), float(cmd[1])
    if limits.actuation == "reference_lag":
        dv = dt * min(max(cv - v, -limits.decel), limits.accel)
        dw = dt * min(max(cw - w, -limits.alpha), limits.alpha)
    else:
        dv = min(max(min(max(cv, limits.v_min), limits.v_max) - v, -limits.decel * dt), limits.accel * dt)
        dw = min(max(min(max(cw, -limits.w_max), limits.w_max) - w, -limits.alpha * dt), limits.alpha * dt)
    v2 = min(max(v + dv, limits.v_min), limits.v_max)
    w2 = min(max(w + dw, -limits.w_max), limits.w_max)
    th2 = th + 0.5 * (w + w2) * dt
    mid = 0.5 * (th + th2)
    dist = 0.5 * (v + v2) * dt
    return np.array([x + dist * float(np.cos(mid)), y + dist * float(np.sin(mid)),
                     (th2 + np.pi) % (2 * np.pi) - np.pi, v2, w2])


def holonomic_step(state: np.ndarray, cmd: np.ndarray, limits: RobotLimits, dt: float) -> np.ndarray:
    """Holonomic robot: cmd (..., 2) is a world-frame velocity (vx, vy) [m/s] tracked within ``accel``.

    The state keeps the same columns: heading = direction of motion (kept when stopped), v = speed,
    omega = realised heading change / dt. Position moves with the mean of old and new velocity.
    """
    state = np.asarray(state, dtype=float)
    cmd = np.asarray(cmd, dtype=float)
    th, v = state[..., TH], state[..., V]
    vel = np.stack([v * np.cos(th), v * np.sin(th)], axis=-1)
    target = cmd.copy()
    tn = np.linalg.norm(target, axis=-1, keepdims=True)
    target *= np.minimum(1.0, limits.v_max / np.where(tn > 0, tn, 1.0))
    dv = target - vel
    dn = np.linalg.norm(dv, axis=-1, keepdims=True)
    dv *= np.minimum(1.0, limits.accel * dt / np.where(dn > 0, dn, 1.0))
    vel2 = vel + dv
    speed = np.linalg.norm(vel2, axis=-1)
    th2 = np.where(speed > 1e-9, np.arctan2(vel2[..., 1], vel2[..., 0]), th)
    out = np.empty(np.broadcast_shapes(state.shape, cmd.shape[:-1] + (5,)))
    out[..., X] = state[..., X] + 0.5 * (vel[..., 0] + vel2[..., 0]) * dt
    out[..., Y] = state[..., Y] + 0.5 * (vel[..., 1] + vel2[..., 1]) * dt
    out[..., TH] = th2
    out[..., V] = speed
    out[..., W] = wrap_angle(th2 - th) / dt
    return out


def robot_step(state: np.ndarray, cmd: np.ndarray, limits: RobotLimits, dt: float) -> np.ndarray:
    """The robot's kinematics for its kind (differential drive or holonomic), batched like ``unicycle_step``."""
    if limits.kind == "holonomic":
        return holonomic_step(state, cmd, limits, dt)
    return unicycle_step(state, cmd, limits, dt)
