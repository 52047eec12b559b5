"""Robot kinematics (pure and vectorised) and the robot's route: spawn, goal, waypoints (reference §2).

``unicycle_step`` is the single implementation of the robot's motion: the simulator calls it on a
(5,) state; ``unicycle_rollout`` gives the same states as calling it once per step over a command
sequence, vectorised over the steps, and the predictive planner rolls out its candidates (B, n) with
it, so they follow exactly the simulator's kinematics. Keep their names and signatures stable.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from functools import lru_cache

import numpy as np

from foresight.core.scenarios.model import RobotConfig

X, Y, TH, V, W = range(
    5
)  #: columns of a robot state (..., 5): x [m], y [m], heading [rad], v [m/s], omega [rad/s]


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
    kind: str = "differential_drive"  #: differential_drive | unicycle | holonomic
    v_pref: float = 2.0  #: preferred (cruising) speed [m/s], at most v_max

    @classmethod
    def from_config(cls, cfg: RobotConfig) -> RobotLimits:
        return cls(
            radius=cfg.radius,
            v_max=cfg.max_linear_speed,
            v_min=-cfg.max_linear_speed if cfg.allow_backwards else 0.0,
            w_max=cfg.max_angular_speed,
            accel=cfg.max_linear_accel,
            decel=cfg.decel,
            alpha=cfg.max_angular_accel,
            actuation=cfg.actuation,
            kind=cfg.kinematics,
            v_pref=cfg.v_pref,
        )

    def as_dict(self) -> dict[str, float]:
        """Numeric limits for ``Observation.robot_limits``; ``holonomic`` 1.0 means commands are (vx, vy)."""
        out = {k: v for k, v in asdict(self).items() if isinstance(v, float)}
        out["holonomic"] = 1.0 if self.kind == "holonomic" else 0.0
        return out


def wrap_angle(a: np.ndarray | float) -> np.ndarray | float:
    """Angle(s) wrapped to [-pi, pi) [rad]: (a + pi) % 2 pi - pi.

    For arrays within one period of the range (the rollouts' headings, differences of two headings) the floor
    remainder is taken by adding or subtracting 2 pi once, which is exactly what ``%`` computes there (fmod is
    exact and returns t itself for |t| < 2 pi, numpy then adds 2 pi to a negative one; t - 2 pi is exact for t in
    [2 pi, 4 pi] by Sterbenz's lemma): the same bits, without numpy's slow float remainder (~3x faster).
    """
    if not isinstance(a, np.ndarray) or a.size < 16:
        return (a + np.pi) % _TWO_PI - np.pi
    t = a + np.pi
    if not (np.minimum.reduce(t, axis=None) >= -_TWO_PI and np.maximum.reduce(t, axis=None) < 2 * _TWO_PI):
        return t % _TWO_PI - np.pi  # (NaN fails the test too)
    t = np.where(t < 0, t + _TWO_PI, np.where(t >= _TWO_PI, t - _TWO_PI, t))
    t -= np.pi
    return t


_TWO_PI = 2 * np.pi


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
    out = np.empty(
        state.shape
        if state.shape[:-1] == cmd.shape[:-1]
        else np.broadcast_shapes(state.shape, cmd.shape[:-1] + (5,))
    )
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
    return np.array(
        [
            x + dist * float(np.cos(mid)),
            y + dist * float(np.sin(mid)),
            (th2 + np.pi) % (2 * np.pi) - np.pi,
            v2,
            w2,
        ]
    )


def unicycle_rollout(state0: np.ndarray, cmds: np.ndarray, limits: RobotLimits, dt: float) -> np.ndarray:
    """States (..., n, 5) after each of n steps of ``unicycle_step`` from ``state0`` (..., 5) under ``cmds`` (..., n, 2).

    The same result as calling ``unicycle_step`` n times (to floating-point rounding; headings agree
    modulo 2 pi, a heading on the wrap boundary may come out as -pi instead of pi), without a Python
    loop over the steps for the default ``tracking`` actuation: under a command held over a run of
    steps the speeds follow a clipped ramp from the run's first speed, and heading and position are
    cumulative sums of the midpoint odometry. Batch shapes broadcast as in ``unicycle_step``; like
    ``unicycle_step`` it ignores ``limits.kind`` (see ``robot_rollout``).
    """
    state0 = np.asarray(state0, dtype=float)
    cmds = np.asarray(cmds, dtype=float)
    n = cmds.shape[-2]
    same = state0.shape[:-1] == cmds.shape[:-2]  # the planner's case: skip the broadcasting calls
    batch = state0.shape[:-1] if same else np.broadcast_shapes(state0.shape[:-1], cmds.shape[:-2])
    out = np.empty(batch + (n, 5))
    if n == 0:
        return out
    s0 = state0 if same else np.broadcast_to(state0, batch + (5,))
    cmds = cmds if same else np.broadcast_to(cmds, batch + (n, 2))
    v0, w0 = s0[..., V], s0[..., W]
    if limits.actuation == "reference_lag":
        v, w = _lag_speeds(v0, w0, cmds, limits, dt)
    else:
        vw = _held_speeds(s0[..., V:], cmds, limits, dt) if n > 1 else None
        v, w = (
            (vw[..., 0, :], vw[..., 1, :]) if vw is not None else _tracking_speeds(v0, w0, cmds, limits, dt)
        )
    # midpoint odometry, accumulated in the order unicycle_step adds (heading unwrapped until the end)
    shape = batch + (n + 1,)
    th = np.empty(shape)
    th[..., 0] = s0[..., TH]
    th[..., 1] = w0
    th[..., 2:] = w[..., :-1]  # previous turn rates
    th[..., 1:] += w
    th[..., 1:] *= 0.5
    th[..., 1:] *= dt  # heading increment of each step
    np.cumsum(th, axis=-1, out=th)
    mid = th[..., 1:] + th[..., :-1]
    mid *= 0.5
    dist = np.empty(batch + (n,))
    dist[..., 0] = v0
    dist[..., 1:] = v[..., :-1]
    dist += v
    dist *= 0.5
    dist *= dt
    acc = np.empty(shape)
    for col, trig in ((X, np.cos), (Y, np.sin)):
        acc[..., 0] = s0[..., col]
        np.multiply(dist, trig(mid), out=acc[..., 1:])
        np.cumsum(acc, axis=-1, out=acc)
        out[..., col] = acc[..., 1:]
    out[..., TH] = wrap_angle(th[..., 1:])
    out[..., V] = v
    out[..., W] = w
    return out


@lru_cache(maxsize=64)
def _ramp_limits(limits: RobotLimits, dt: float) -> tuple[np.ndarray, ...]:
    """(2, 1) lower/upper bounds and per-step down/up changes of (v, omega), for :func:`_held_speeds`."""
    col = [
        [limits.v_min, -limits.w_max],
        [limits.v_max, limits.w_max],
        [limits.decel * dt, limits.alpha * dt],
        [limits.accel * dt, limits.alpha * dt],
    ]
    return tuple(np.array(c)[:, None] for c in col)


def _held_speeds(vw0: np.ndarray, cmds: np.ndarray, limits: RobotLimits, dt: float) -> np.ndarray | None:
    """``_tracking_speeds`` as (..., 2, n) [v; omega] when every sequence holds ONE command within the limits
    (the planner's rollouts), else None: the same ramp formulas, v and omega in one array op each and
    without the run detection (numpy's per-call overhead dominates at the planner's sizes)."""
    flat = cmds.reshape(cmds.shape[:-2] + (-1,))  # (..., 2 n): each step equal to the one before it
    if not np.logical_and.reduce(flat[..., 2:] == flat[..., :-2], axis=None):
        return None
    lo, hi, down, up = _ramp_limits(limits, dt)
    if not np.logical_and.reduce((vw0 >= lo[:, 0]) & (vw0 <= hi[:, 0]), axis=None):
        return None
    k = np.arange(1, cmds.shape[-2] + 1, dtype=float)
    return _ramp(vw0, _clip(cmds[..., 0, :], lo[:, 0], hi[:, 0]), lo, hi, down, up, k)


def _tracking_speeds(
    v0: np.ndarray, w0: np.ndarray, cmds: np.ndarray, limits: RobotLimits, dt: float
) -> tuple[np.ndarray, np.ndarray]:
    """Speeds (..., n) of ``tracking`` actuation: per run of steps with the same (clipped) command, a ramp
    within the acceleration limits toward the command, in closed form."""
    cv = _clip(cmds[..., 0], limits.v_min, limits.v_max)
    cw = _clip(cmds[..., 1], -limits.w_max, limits.w_max)
    n = cv.shape[-1]
    changed = (cv[..., 1:] != cv[..., :-1]) | (cw[..., 1:] != cw[..., :-1])  # a new run starts after a change
    starts = np.flatnonzero(changed.reshape(-1, n - 1).any(axis=0)) + 1 if n > 1 else []
    bounds = [0, *(int(i) for i in starts), n]
    k = np.arange(1, n + 1, dtype=float)
    v = np.empty(cv.shape)
    w = np.empty(cw.shape)
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        kk = k[: b - a]
        va = v0 if a == 0 else v[..., a - 1]
        wa = w0 if a == 0 else w[..., a - 1]
        v[..., a:b] = _held_ramp(
            va, cv[..., a], limits.v_min, limits.v_max, limits.decel * dt, limits.accel * dt, kk
        )
        w[..., a:b] = _held_ramp(
            wa, cw[..., a], -limits.w_max, limits.w_max, limits.alpha * dt, limits.alpha * dt, kk
        )
    return v, w


def _held_ramp(
    x0: np.ndarray, target: np.ndarray, lo: float, hi: float, down: float, up: float, k: np.ndarray
) -> np.ndarray:
    """x after steps k = 1..L (..., L) of x <- clip(x + clip(target - x, -down, up), lo, hi), target in [lo, hi].

    From x0 within [lo, hi] every step stays between x0 and the target, so the speed clip never acts and
    x_k = x0 + clip(target - x0, -k down, k up) (clipped once more against rounding). A start outside the
    limits (never after a simulator step) takes its first step exactly, which lands inside them.
    """
    x0 = np.asarray(x0, dtype=float)
    if not np.all((x0 >= lo) & (x0 <= hi)):
        x1 = _clip(x0 + _clip(target - x0, -down, up), lo, hi)
        if len(k) == 1:
            return x1[..., None]
        rest = _ramp(x1, target, lo, hi, down, up, k[:-1])
        return np.concatenate([x1[..., None], rest], axis=-1)
    return _ramp(x0, target, lo, hi, down, up, k)


def _ramp(
    x0: np.ndarray, target: np.ndarray, lo: float, hi: float, down: float, up: float, k: np.ndarray
) -> np.ndarray:
    x0 = x0[..., None]
    return _clip(x0 + np.minimum(np.maximum(target[..., None] - x0, -down * k), up * k), lo, hi)


def _lag_speeds(
    v0: np.ndarray, w0: np.ndarray, cmds: np.ndarray, limits: RobotLimits, dt: float
) -> tuple[np.ndarray, np.ndarray]:
    """Speeds (..., n) of ``reference_lag`` actuation: the first-order lag is stepped as ``unicycle_step`` does
    (only the speeds loop over the steps; the pose is vectorised by the caller)."""
    n = cmds.shape[-2]
    v_all = np.empty(cmds.shape[:-1])
    w_all = np.empty(cmds.shape[:-1])
    v, w = v0, w0
    for i in range(n):
        v = _clip(
            v + dt * _clip(cmds[..., i, 0] - v, -limits.decel, limits.accel), limits.v_min, limits.v_max
        )
        w = _clip(
            w + dt * _clip(cmds[..., i, 1] - w, -limits.alpha, limits.alpha), -limits.w_max, limits.w_max
        )
        v_all[..., i] = v
        w_all[..., i] = w
    return v_all, w_all


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


def turn_first_step(state: np.ndarray, cmd: np.ndarray, limits: RobotLimits, dt: float) -> np.ndarray:
    """Unicycle robot (CrowdNav's): speeds (v, omega) follow the command as in ``unicycle_step`` (tracking within
    the acceleration limits), then the robot turns by omega' dt and moves v' dt along its new heading."""
    state = np.asarray(state, dtype=float)
    cmd = np.asarray(cmd, dtype=float)
    v, w = state[..., V], state[..., W]
    dv = _clip(_clip(cmd[..., 0], limits.v_min, limits.v_max) - v, -limits.decel * dt, limits.accel * dt)
    dw = _clip(_clip(cmd[..., 1], -limits.w_max, limits.w_max) - w, -limits.alpha * dt, limits.alpha * dt)
    v2 = _clip(v + dv, limits.v_min, limits.v_max)
    w2 = _clip(w + dw, -limits.w_max, limits.w_max)
    th2 = state[..., TH] + w2 * dt
    out = np.empty(np.broadcast_shapes(state.shape, cmd.shape[:-1] + (5,)))
    out[..., X] = state[..., X] + v2 * dt * np.cos(th2)
    out[..., Y] = state[..., Y] + v2 * dt * np.sin(th2)
    out[..., TH] = wrap_angle(th2)
    out[..., V] = v2
    out[..., W] = w2
    return out


_STEPS = {"holonomic": holonomic_step, "unicycle": turn_first_step}


def robot_step(state: np.ndarray, cmd: np.ndarray, limits: RobotLimits, dt: float) -> np.ndarray:
    """The robot's kinematics for its kind (differential drive, unicycle or holonomic), batched like
    ``unicycle_step``."""
    return _STEPS.get(limits.kind, unicycle_step)(state, cmd, limits, dt)


def robot_rollout(state0: np.ndarray, cmds: np.ndarray, limits: RobotLimits, dt: float) -> np.ndarray:
    """``robot_step`` repeated over cmds (..., n, 2): states (..., n, 5); ``unicycle_rollout`` for differential drive."""
    step = _STEPS.get(limits.kind)
    if step is None:
        return unicycle_rollout(state0, cmds, limits, dt)
    cmds = np.asarray(cmds, dtype=float)
    s = np.asarray(state0, dtype=float)
    out = np.empty(np.broadcast_shapes(s.shape[:-1], cmds.shape[:-2]) + (cmds.shape[-2], 5))
    for i in range(cmds.shape[-2]):
        s = step(s, cmds[..., i, :], limits, dt)
        out[..., i, :] = s
    return out
