"""Could the robot have avoided a pedestrian contact? A check on the stored trace for the taxonomy.

A collision is only the pedestrian's fault when no admissible robot motion, started from the robot's
recorded state at the moment the conflict became visible, avoids it. "Became visible" is the later of
the critical pedestrian's first recorded step (its spawn: the planner observes every pedestrian in the
map, there is no sensing range) and a fixed look-back before the contact (``TaxonomyConfig.fault_lookback_s``,
default 3 s: more than the planner's 2.4 s prediction horizon, so a conflict a constant-velocity look-ahead
could see counts as seen).

Admissible motions are piecewise-constant command sequences sampled over the robot's own limits and
actuation model (``core.sim.robot.robot_rollout``, the simulator's kinematics): for differential drive every
combination of a speed target in {v_min, 0, v_max/2, v_max} and a turn-rate target in
{-w_max, -w_max/2, 0, w_max/2, w_max}, re-chosen at the start of each of ``SEGMENTS`` equal parts of the
window; for a holonomic robot, world-frame velocity targets (8 directions at v_max and v_max/2, plus stop).
A motion avoids the contact when, from the decision step to the contact step plus ``fault_extension_s``
(pedestrians extrapolated at their last recorded velocity beyond the trace), its centre distance to every
pedestrian recorded in the trace stays above the two radii and, when the map is known, its distance to
every obstacle edge and map bound stays above the robot radius. The other pedestrians' recorded motion
is taken as given (they reacted to the robot's actual path): an approximation that can only err towards
"avoidable" where their reaction would have closed the escape, never towards excusing the planner.
"""

from __future__ import annotations

import itertools
from functools import lru_cache

import numpy as np

from foresight.core.sim.observation import StaticGeometry
from foresight.core.sim.robot import RobotLimits, robot_rollout

SEGMENTS = 3  #: command changes allowed over the window (at its start and at 1/3 and 2/3 of it)


@lru_cache(maxsize=16)
def _segment_commands(limits: RobotLimits) -> np.ndarray:
    """(C, 2) commands one segment may hold: extreme and middle targets within the limits."""
    if limits.kind == "holonomic":
        ang = np.arange(8) * (np.pi / 4)
        dirs = np.column_stack([np.cos(ang), np.sin(ang)])
        return np.vstack([dirs * limits.v_max, dirs * (limits.v_max / 2), [[0.0, 0.0]]])
    speeds = sorted({limits.v_min, 0.0, limits.v_max / 2, limits.v_max})
    turns = (-limits.w_max, -limits.w_max / 2, 0.0, limits.w_max / 2, limits.w_max)
    return np.array(list(itertools.product(speeds, turns)), dtype=float)


def command_sequences(limits: RobotLimits, n_window: int, n_total: int) -> np.ndarray:
    """(B, n_total, 2) sampled command sequences: ``SEGMENTS`` equal parts of the first ``n_window`` steps,
    each holding one segment command, the last one held to ``n_total``."""
    cmds = _segment_commands(limits)
    combos = np.array(list(itertools.product(range(len(cmds)), repeat=SEGMENTS)))  # (B, SEGMENTS)
    part = np.minimum(np.arange(n_total) * SEGMENTS // max(n_window, 1), SEGMENTS - 1)  # segment of each step
    return cmds[combos[:, part]]


def escape_exists(
    robot: np.ndarray,
    ped_ids: np.ndarray,
    ped_pos: np.ndarray,
    ped_vel: np.ndarray,
    *,
    start: int,
    contact: int,
    dt: float,
    limits: RobotLimits,
    robot_radius: float,
    ped_radius: float,
    extension_steps: int,
    static: StaticGeometry | None = None,
) -> bool:
    """Whether a sampled admissible motion from state ``start`` keeps clear of every pedestrian (and of the
    map, when ``static`` is given) up to ``contact + extension_steps`` (see the module docstring).
    Arrays are the trace's (T+1, ...); the radii are the episode's (``limits`` gives the dynamics)."""
    n_window = contact - start
    if n_window <= 0:
        return False
    n = n_window + extension_steps
    # pedestrian positions at states start+1 .. contact, then extrapolated at their last velocity
    rec_pos, rec_ids = ped_pos[start + 1 : contact + 1], ped_ids[start + 1 : contact + 1]
    k = np.arange(1, extension_steps + 1, dtype=float)[:, None, None]
    ext_pos = ped_pos[contact][None] + k * dt * ped_vel[contact][None]
    pos = np.concatenate([rec_pos, ext_pos])  # (n, N, 2)
    valid = np.concatenate([rec_ids >= 0, np.repeat(ped_ids[contact][None] >= 0, extension_steps, axis=0)])
    state0 = robot[start]
    contact_distance = robot_radius + ped_radius
    # only pedestrians the robot could reach at all in the window matter
    reach = abs(state0[3]) * n * dt + 0.5 * limits.accel * (n * dt) ** 2 + contact_distance
    near = (valid & (np.linalg.norm(pos - state0[:2], axis=-1) <= reach)).any(axis=0)
    pos, valid = pos[:, near], valid[:, near]
    cmds = command_sequences(limits, n_window, n)
    xy = robot_rollout(np.broadcast_to(state0, (len(cmds), 5)), cmds, limits, dt)[..., :2]  # (B, n, 2)
    clear = np.ones(len(cmds), dtype=bool)
    for i in range(n if pos.shape[1] else 0):  # one step at a time keeps memory at (B, N')
        gap = np.linalg.norm(xy[:, i, None, :] - pos[i][None], axis=-1)
        clear &= ~((gap <= contact_distance) & valid[i]).any(axis=1)
    if static is not None:
        for i in range(n):
            idx = np.flatnonzero(clear)
            if idx.size == 0:
                break
            clear[idx] = static.distance(xy[idx, i]) > robot_radius
    return bool(clear.any())
