"""Beam search over command sequences: the first round's candidates, then ``beam_width`` kept per branching round.

The first round holds first-segment candidates (dense in the near field) to the horizon and adds point turns and
swerves (``sampling``), and the last decision's plan one step on (``search.keep_plan``); each later segment
boundary extends the cheapest sequences so far with a coarser command set. Rollouts come from ``FrameRollouts``
(the robot's own kinematics); stable sorts keep it deterministic.
"""

from __future__ import annotations

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.planners.predictive import cost as C
from foresight.core.planners.predictive import holonomic
from foresight.core.planners.predictive.config import PredictivePlannerConfig
from foresight.core.planners.predictive.rollout import FrameRollouts, eval_steps
from foresight.core.planners.predictive.sampling import (
    branch_commands,
    first_candidates,
    holonomic_branches,
    holonomic_candidates,
    reverse_speeds,
    turn_then_go,
    veer_then_straight,
)
from foresight.core.sim.observation import Observation
from foresight.core.sim.robot import RobotLimits, robot_step

Plan = tuple[np.ndarray, np.ndarray]  #: a decision's commands (S, 2) and rollout states (S, 5)


class BeamSearch:
    """One episode's search; its command sets and step grids are cached for the episode (read-only arrays)."""

    def __init__(
        self, config: PredictivePlannerConfig, limits: RobotLimits, holonomic: bool, frames: FrameRollouts
    ):
        self.config, self.limits, self.holonomic, self.frames = config, limits, holonomic, frames
        self._cands: dict[bool | None, np.ndarray] = {}
        self._firsts: dict[tuple, np.ndarray] = {}  #: (near field, steps) -> the first round's sequences
        self._step_cache: dict[tuple, tuple] = {}

    def candidates(self, near: bool | None) -> np.ndarray:
        """First-segment commands (near field or not), or the later-segment set for ``None``."""
        if near not in self._cands:
            cfg, limits, ratio = self.config, self.limits, self.config.max_speed_ratio
            if self.holonomic:
                self._cands[near] = (
                    holonomic_branches(cfg.search, limits, ratio)
                    if near is None
                    else holonomic_candidates(cfg.sampling, limits, ratio, near)
                )
            else:
                self._cands[near] = (
                    branch_commands(cfg.search, limits, ratio, reverse_speeds(cfg.sampling, limits, ratio))
                    if near is None
                    else first_candidates(cfg.sampling, limits, ratio, near)
                )
        return self._cands[near]

    def first_sequences(self, near: bool, steps: int, dt: float) -> np.ndarray:
        """The first round's sequences (C + P + V, steps, 2): the first-segment candidates held to the horizon, then the
        point turns (``sampling.point_turns``) and the swerves (``sampling.veers``)."""
        key = (near, steps)
        if key not in self._firsts:
            cfg = self.config
            held = np.repeat(self.candidates(near)[:, None, :], steps, axis=1)
            if self.holonomic:  # it moves any way at once: no point turns or swerves to add
                seqs = held
            else:
                turns = turn_then_go(cfg.sampling, self.limits, steps, dt, cfg.max_speed_ratio)
                veers = veer_then_straight(cfg.sampling, self.limits, steps, dt, cfg.max_speed_ratio)
                seqs = np.concatenate([held, turns, veers])
            seqs.flags.writeable = False
            self._firsts[key] = seqs
        return self._firsts[key]

    def steps(self, times: np.ndarray, sim_dt: float) -> tuple[np.ndarray, int, list[int]]:
        """Rollout step of each forecast time, rollout length and segment boundaries."""
        key = (times.tobytes(), sim_dt)
        cached = self._step_cache.get(key)
        if cached is None:
            idx = eval_steps(times, sim_dt)
            S = int(idx[-1]) + 1
            cached = self._step_cache[key] = (idx, S, boundaries(self.config.search.segments_s, sim_dt, S))
        return cached

    def costed(self, cmds: np.ndarray) -> np.ndarray:
        """The commands as the cost reads them: themselves, or a holonomic robot's as (speed, bearing)."""
        return holonomic.cost_commands(cmds, self.limits) if self.holonomic else cmds

    def __call__(
        self, obs: Observation, scene: C.Scene, near: bool, last: Plan | None
    ) -> tuple[np.ndarray, dict, float, int, bool, Plan]:
        """The best sequence's commands (S, 2), its terms, its cost, #evaluations, whether it is the last decision's
        plan ``last`` carried on, and the plan it makes."""
        cfg = self.config
        sim_dt = obs.dt
        idx, S, bounds = self.steps(scene.times, sim_dt)
        state0 = np.concatenate([obs.robot_pose, obs.robot_velocity]).astype(float)
        cmds = self.first_sequences(near, S, sim_dt)  # (C + P, S, 2)
        states = self.frames(state0[None], cmds, ("first", near, S))
        kept = None
        if cfg.search.keep_plan and not self.holonomic:
            kept = kept_plan(last, state0, S, sim_dt, self.limits)
        if kept is not None:
            cmds, states = np.concatenate([cmds, kept[0][None]]), np.concatenate([states, kept[1][None]])
        total, terms = C.evaluate(C.Rollouts(states, idx, self.costed(cmds)), scene, cfg)
        evals = [
            (cmds, states, total, terms)
        ]  # (commands, states, totals, terms) of each evaluation, in order
        n_eval = len(cmds)
        branch = self.candidates(None)
        M = len(branch)
        for b in bounds:
            keep = np.argsort(_joined(evals, 2), kind="stable")[: cfg.search.beam_width]
            p_cmds, p_states = _joined(evals, 0)[keep], _joined(evals, 1)[keep]
            new_cmds = np.repeat(p_cmds, M, axis=0)
            new_cmds[:, b:] = np.tile(branch, (len(keep), 1))[:, None, :]
            tail = self.frames(p_states[:, b - 1], new_cmds[:M, b:], ("branch", b, S))
            new_states = np.concatenate([np.repeat(p_states[:, :b], M, axis=0), tail], axis=1)
            t_new, terms_new = C.evaluate(C.Rollouts(new_states, idx, self.costed(new_cmds)), scene, cfg)
            n_eval += len(new_cmds)
            evals.append((new_cmds, new_states, t_new, terms_new))
        best = int(np.argmin(_joined(evals, 2)))
        e = 0
        while best >= len(evals[e][2]):  # find the evaluation that holds ``best``
            best -= len(evals[e][2])
            e += 1
        cmds, states, total, terms = evals[e]
        carried_on = (
            kept is not None and e == 0 and best == len(cmds) - 1
        )  # the kept plan is the first round's last
        terms_best = {k: v[best] for k, v in terms.items()}
        return cmds[best], terms_best, float(total[best]), n_eval, carried_on, (cmds[best], states[best])


def kept_plan(plan: Plan | None, state0: np.ndarray, S: int, dt: float, limits: RobotLimits) -> Plan | None:
    """The last decision's sequence one step on, its last command held, and its rollout (``search.keep_plan``).

    The robot carried out the plan's first command with the rollout's own kinematics, so it stands where the
    plan's first state is and the rest of that rollout is this plan's, but for one more step at the end;
    anything else (the first decision, another horizon, a robot moved otherwise) gets no kept plan."""
    if plan is None or len(plan[0]) != S:
        return None
    cmds, states = plan
    if np.max(np.abs(states[0, [0, 1, 3, 4]] - state0[[0, 1, 3, 4]])) > 1e-6:
        return None
    cmds = np.concatenate([cmds[1:], cmds[-1:]])
    last = robot_step(states[-1], cmds[-1], limits, dt)
    return cmds, np.concatenate([states[1:], last[None]])


def boundaries(segments_s: tuple[float, ...], sim_dt: float, S: int) -> list[int]:
    """Simulator-step indices where segments 2.. start (strictly inside the horizon)."""
    out, acc = [], 0
    for d in segments_s:
        acc += max(1, int(round(d / sim_dt)))
        if acc >= S:
            break
        out.append(acc)
    if not out and segments_s:
        raise ConfigError(
            f"segments {segments_s} s leave no second segment inside the {S * sim_dt:.1f} s horizon",
            item="search.segments_s",
        )
    return out


def _joined(evals: list[tuple], field: int) -> np.ndarray:
    """One field of every evaluation so far, in order (the first one's own array while it is alone: the default
    search has one branching round, so its states and commands are never copied into a pool)."""
    return evals[0][field] if len(evals) == 1 else np.concatenate([e[field] for e in evals])
