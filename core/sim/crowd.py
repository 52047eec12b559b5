"""One crowd step: sum the social-force terms, integrate with a per-ped speed cap, keep peds out of walls.

Per-episode constants (intra-group pairs, the neighbour cutoff, segment arrays) are computed once
at construction so that a step is a short sequence of fused array operations.
"""

from __future__ import annotations

import numpy as np

from foresight.core.sim import forces
from foresight.core.sim.behaviours import CrowdArrays
from foresight.core.sim.forces import as_complex, as_xy
from foresight.core.sim.geometry import SegmentSet
from foresight.core.sim.neighbours import cell_pairs
from foresight.core.sim.params import CrowdParams, ForceParams
from foresight.core.sim.walls import constrain_moves


def _group_pairs(group: np.ndarray, size: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ordered same-group pairs (i, j), i != j, as two int arrays (groups never change members)."""
    firsts, seconds = [np.zeros(0, dtype=np.intp)], [np.zeros(0, dtype=np.intp)]
    for g in np.nonzero(size >= 2)[0]:
        rows = np.nonzero(group == g)[0]
        i, j = np.meshgrid(rows, rows, indexing="ij")
        keep = i != j
        firsts.append(i[keep])
        seconds.append(j[keep])
    return np.concatenate(firsts), np.concatenate(seconds)


class CrowdDynamics:
    """Forces and integration for a fixed set of N pedestrians on one static map."""

    def __init__(
        self,
        crowd: CrowdArrays,
        walls: SegmentSet,
        params: ForceParams,
        crowd_params: CrowdParams,
        *,
        dt: float,
        robot_radius: float,
        obstacle_forces: bool,
        robot_repulsion: bool,
        semi_implicit: bool,
        robot_reach: np.ndarray | None = None,
    ):
        """``robot_reach`` (N,): per-ped robot reaction range [m] (``core.sim.attention``); None = the force's cutoff."""
        self.c = crowd
        self.walls = walls
        self.p = params
        self.cp = crowd_params
        self.dt = dt
        self.robot_radius = robot_radius
        self.obstacle_forces = obstacle_forces and len(walls) > 0
        cutoff = params.robot_cutoff(robot_radius)
        if robot_reach is not None and (robot_reach >= cutoff).all():
            robot_reach = None  # everyone reacts at the cutoff: the scalar test is the same and cheaper
        self.robot_reach = robot_reach
        self.robot_repulsion = robot_repulsion and (robot_reach is None or bool((robot_reach > 0).any()))
        self.semi_implicit = semi_implicit
        n = len(crowd.pos)
        self.n = n
        self.cutoff = params.social_cutoff(float(crowd.vmax.max()) if n else 0.0)  #: ped-ped cutoff [m]
        self.dense = n <= crowd_params.dense_pair_limit
        self.gi, self.gj = _group_pairs(crowd.group, crowd.group_size)
        self.has_groups = bool((crowd.group_size >= 2).any())
        self.member_n = crowd.group_size[crowd.group]  #: (N,) size of each ped's group
        self.wall_constraint = crowd_params.wall_constraint and len(walls) > 0
        # a ped moves at most vmax dt per step (speeds are capped), so only peds this close to a
        # segment can reach it: a per-episode bound saves computing every move's length
        self.reach = crowd.vmax * dt + 2 * crowd_params.wall_clearance  #: (N,) [m]

    def pairs(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        """Neighbour pairs for the ped-ped force: None = all pairs (dense, masked by the cutoff), else the cell list's."""
        return (None, None) if self.dense else cell_pairs(self.c.pos, self.cutoff)

    def total_force(
        self, robot: complex, centroids: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Sum of all active terms (N,) complex [m/s^2], plus each ped's wall clearance (N,) when computed.

        ``robot``: the robot centre x + iy [m]; ``centroids`` (G,) complex: group centroids of the
        current positions when the caller has them.
        """
        c, p = self.c, self.p
        f = forces.desired_force(c.z, c.zv, c.zgoal, c.vmax, p)
        i, j = self.pairs()
        f += forces.social_force(c.z, c.zv, i, j, p, self.cutoff if i is None else None)
        clearance = None
        if self.obstacle_forces:
            fo, clearance = forces.obstacle_force(c.z, self.walls, p)
            f += fo
        if self.has_groups:
            if centroids is None:
                centroids = forces.group_centroids(c.z, c.group, c.group_size)
            cent = centroids[c.group]
            f += forces.group_coherence_force(c.z, cent, self.member_n, p)
            f += forces.group_repulsion_force(c.z, self.gi, self.gj, p)
            f += forces.group_gaze_force(c.z, c.zgoal, cent, self.member_n, p)
        if self.robot_repulsion:
            fr = forces.robot_force(c.z, robot, self.robot_radius, p, self.robot_reach)
            f += fr if c.robot_response is None else fr * c.robot_response
        return f, clearance

    def step(self, robot: complex, centroids: np.ndarray | None = None) -> None:
        """Advance all pedestrians by dt (robot at its pose before it moves, as the reference)."""
        if self.n == 0:
            return
        c = self.c
        f, clearance = self.total_force(robot, centroids)
        v = c.zv + self.dt * f
        speed = forces.norm(v)
        v *= np.where(speed > c.vmax, c.vmax / np.maximum(speed, 1e-300), 1.0)  # per-ped speed cap
        new = c.z + self.dt * (v if self.semi_implicit else c.zv)
        if self.wall_constraint:
            self._constrain(new, v, clearance)
        c.z[:] = new
        c.zv[:] = v

    def _constrain(self, new: np.ndarray, v: np.ndarray, clearance: np.ndarray | None) -> None:
        """Apply the wall constraint (in place on ``new``, ``v``) to the peds that could reach a segment."""
        c = self.c
        if clearance is None:
            clearance = self.walls.distance(c.pos)
        close = clearance <= self.reach
        if not close.any():
            return
        near = np.nonzero(close)[0]
        fixed, fv = constrain_moves(
            self.walls, c.pos[near], as_xy(new[near]), as_xy(v[near]), self.cp.wall_clearance
        )
        new[near] = as_complex(fixed)
        v[near] = as_complex(fv)
