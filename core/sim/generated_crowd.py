"""CrowdNav's crowd: humans placed by its generators, moved by ORCA, new goals or respawns by its rules.

Facts from CrowdNav (vita-epfl/CrowdNav, ``crowd_sim/envs/crowd_sim.py``) and CrowdNav++
(Shuijing725/CrowdNav_Prediction_AttnGraph, ``crowd_sim/envs/crowd_sim.py`` and ``crowd_sim_var_num.py``); the code
is ours. Every random draw goes through one ``numpy.random.RandomState(seed)`` of the episode in CrowdNav's order
(robot, then each human: attributes, then placement tries), so seed s gives CrowdNav's case for
``np.random.seed(s)``. Coordinates here are the generator's (origin at ``CrowdGenerator.centre``); the simulator
sees map coordinates (``pos`` etc. are already shifted).
"""

from __future__ import annotations

import math

import numpy as np

from foresight.core.scenarios.crowd_models import CrowdGenerator, OrcaPedestrians
from foresight.core.sim.orca_agents import OrcaAgents


class GeneratedCrowd:
    """The humans of one episode: (N,) arrays in map coordinates, stepped by ORCA (``step``)."""

    def __init__(
        self,
        gen: CrowdGenerator,
        orca: OrcaPedestrians,
        seed: int,
        robot_radius: float,
        ped_radius: float,
        dt: float,
        obstacles: list[np.ndarray],
    ):
        self.gen, self.orca, self.dt = gen, orca, dt
        self.rs = np.random.RandomState(int(seed) & 0xFFFFFFFF)
        self.centre = np.asarray(gen.centre, dtype=float)
        self.robot_radius, self.base_radius = robot_radius, ped_radius
        self.robot_start, self.robot_goal = self._robot()
        n = gen.human_num
        self.pos, self.vel, self.goal = np.zeros((n, 2)), np.zeros((n, 2)), np.zeros((n, 2))
        self.vmax, self.radius = np.zeros(n), np.zeros(n)
        self.ids = np.arange(n, dtype=np.int64)
        self.next_id = n
        robot_now = self.robot_start
        for i in range(n):
            self._place(i, i, robot_now)
        self.pos += self.centre
        self.goal += self.centre
        self.t = 0
        self.agents = OrcaAgents(n + int(orca.robot_visible), orca, dt, obstacles)

    @property
    def randomized(self) -> bool:
        return self.gen.randomize_attributes

    # -- generation (generator coordinates) -------------------------------------------------------
    def _robot(self) -> tuple[np.ndarray, np.ndarray]:
        g, rs = self.gen, self.rs
        if g.robot_rule == "fixed":
            return np.array([0.0, -g.circle_radius]), np.array([0.0, g.circle_radius])
        while True:
            px, py, gx, gy = rs.uniform(-g.arena_size, g.arena_size, 4)
            if math.hypot(px - gx, py - gy) >= g.robot_min_travel:
                return np.array([px, py]), np.array([gx, gy])

    def _attributes(self) -> tuple[float, float]:
        g = self.gen
        if not g.randomize_attributes:
            return g.human_speed, self.base_radius
        v = self.rs.uniform(*g.speed_range)
        return float(v), float(self.rs.uniform(*g.radius_range))

    def _clear(
        self, p: np.ndarray, r: float, others: np.ndarray, robot: np.ndarray, goals_only=False
    ) -> bool:
        """CrowdNav's placement test (generator coordinates): ``p`` farther than r + r_other + discomfort from the
        robot (its position and goal) and the humans ``others`` (row indices: their positions and goals). A square
        crossing's start is tested against positions only and its goal (``goals_only``) against goals only."""
        d = self.gen.discomfort_dist
        agents = [(robot, self.robot_goal, self.robot_radius)]
        agents += [(self.pos[j], self.goal[j], float(self.radius[j])) for j in others]
        for a_pos, a_goal, a_r in agents:
            m = r + a_r + d
            if not goals_only and math.hypot(p[0] - a_pos[0], p[1] - a_pos[1]) < m:
                return False
            if (goals_only or not self._square) and math.hypot(p[0] - a_goal[0], p[1] - a_goal[1]) < m:
                return False
        return True

    @property
    def _square(self) -> bool:
        return self.gen.rule == "square_crossing"

    def _circle_point(self, v_pref: float, noise: str) -> np.ndarray:
        rs, g = self.rs, self.gen
        angle = rs.random_sample() * np.pi * 2
        if noise == "positive":
            nx, ny = rs.uniform(0, 1) * 2.0, rs.uniform(0, 1) * 2.0
        else:
            scale = 1.0 if v_pref == 0 else v_pref
            nx, ny = (rs.random_sample() - 0.5) * scale, (rs.random_sample() - 0.5) * scale
        return np.array([g.circle_radius * np.cos(angle) + nx, g.circle_radius * np.sin(angle) + ny])

    def _place(self, i: int, n_before: int, robot: np.ndarray, others: np.ndarray | None = None) -> None:
        """Draw human ``i`` (attributes, then start and goal) against the robot and ``others`` (default: the
        ``n_before`` humans placed before it); generator coordinates in, stored as they are."""
        v, r = self._attributes()
        others = np.arange(n_before) if others is None else others
        if self._square:
            start, goal = self._square_human(r, others, robot)
        else:
            while True:
                start = self._circle_point(v, self.gen.start_noise)
                if self._clear(start, r, others, robot):
                    break
            goal = -start
        self.pos[i], self.goal[i], self.vel[i], self.vmax[i], self.radius[i] = start, goal, 0.0, v, r

    def _square_human(self, r: float, others: np.ndarray, robot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rs, w = self.rs, self.gen.square_width
        sign = -1.0 if rs.random_sample() > 0.5 else 1.0
        while True:
            start = np.array([rs.random_sample() * w * 0.5 * sign, (rs.random_sample() - 0.5) * w])
            if self._clear(start, r, others, robot):
                break
        while True:
            goal = np.array([rs.random_sample() * w * 0.5 * -sign, (rs.random_sample() - 0.5) * w])
            if self._clear(goal, r, others, robot, goals_only=True):
                return start, goal

    # -- one step -----------------------------------------------------------------------------------
    def step(self, robot: np.ndarray, robot_vel: np.ndarray) -> None:
        """Move every human by one ORCA step (the robot at its pose before it moves, as CrowdNav)."""
        to_goal = self.goal - self.pos
        dist = np.hypot(to_goal[:, 0], to_goal[:, 1])
        # CrowdNav's preferred velocity: toward the goal at 1 m/s (the max speed caps it), the goal vector itself
        # within 1 m
        pref = np.where(dist[:, None] > 1.0, to_goal / np.maximum(dist, 1e-12)[:, None], to_goal)
        margin = 0.01 + self.orca.safety_space
        pos, vel, rad, vmax = [self.pos], [self.vel], [self.radius + margin], [self.vmax]
        if self.orca.robot_visible:
            pos.append(robot[None, :2])
            vel.append(robot_vel[None])
            pref = np.vstack([pref, robot_vel[None]])
            rad.append(np.array([self.robot_radius + margin]))
            vmax.append(np.array([max(float(np.hypot(*robot_vel)), 1e-3)]))
        new_vel = self.agents.step(
            np.vstack(pos), np.vstack(vel), pref, np.concatenate(rad), np.concatenate(vmax)
        )
        n = len(self.pos)
        self.vel = new_vel[:n]
        self.pos = self.pos + self.vel * self.dt
        self.t += 1
        self._goals(robot)

    def _goals(self, robot: np.ndarray) -> None:
        """CrowdNav++'s goal rules after the move: every ``goal_change_interval_s`` each human may get a new goal on
        the circle; a human within its radius of its goal stays, respawns or walks on (``at_goal``)."""
        g = self.gen
        robot_local = robot[:2] - self.centre
        self._to_local()
        try:
            every = int(round(g.goal_change_interval_s / self.dt))
            if g.goal_change_chance > 0 and self.t % every == 0:
                for i in range(len(self.pos)):
                    if self.vmax[i] == 0 or self.rs.random_sample() > g.goal_change_chance:
                        continue
                    others = np.array([j for j in range(len(self.pos)) if j != i], dtype=np.intp)
                    self.goal[i] = self._new_goal(i, others, robot_local)
            if g.at_goal == "stay":
                return
            for i in range(len(self.pos)):
                if math.hypot(*(self.goal[i] - self.pos[i])) >= self.radius[i]:
                    continue
                if g.at_goal == "respawn":
                    self._place(i, len(self.pos), robot_local, others=np.arange(len(self.pos)))
                    self.ids[i] = self.next_id
                    self.next_id += 1
                elif self.rs.random_sample() <= 1.0:  # CrowdNav++ draws its end-goal chance (1.0) first
                    others = np.array([j for j in range(len(self.pos)) if j != i], dtype=np.intp)
                    self.goal[i] = self._new_goal(i, others, robot_local)
        finally:
            self._to_map()

    def _new_goal(self, i: int, others: np.ndarray, robot: np.ndarray) -> np.ndarray:
        while True:
            goal = self._circle_point(float(self.vmax[i]), "symmetric")
            if self._clear(goal, float(self.radius[i]), others, robot):
                return goal

    def _to_local(self) -> None:
        self.pos, self.goal = self.pos - self.centre, self.goal - self.centre

    def _to_map(self) -> None:
        self.pos, self.goal = self.pos + self.centre, self.goal + self.centre
