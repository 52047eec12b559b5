"""The toy planner with one fault switched on per config flag: the conformance check must name each one."""

from __future__ import annotations

import math
import random
import time

from foresight_toy_planner import ToyConfig, ToyPlanner


class BrokenConfig(ToyConfig):
    nan: bool = False  #: a NaN turn rate from the fifth decision on
    too_fast: bool = False  #: twice the robot's top speed
    noisy: bool = False  #: global random noise: other commands on the same seed
    slow_s: float = 0.0  #: sleeps this long per decision
    no_crowd: bool = False  #: fails with zero pedestrians (the nearest of none)
    big_crowd: bool = False  #: fails with more than 100 pedestrians
    leaky: bool = False  #: keeps a step counter across episodes (reset does not clear it)


class BrokenToy(ToyPlanner):
    name = "broken_toy"
    config_model = BrokenConfig

    def __init__(self, config: BrokenConfig):
        super().__init__(config)
        self.decisions = 0

    def reset(self, info) -> None:  # noqa: ANN001
        super().reset(info)
        if not self.config.leaky:
            self.decisions = 0

    def plan(self, obs) -> tuple[float, float]:  # noqa: ANN001
        c = self.config
        v, w = super().plan(obs)
        self.decisions += 1
        n = len(obs.ped_positions)
        if c.no_crowd:
            w += 0.0 * min(
                math.hypot(*p) for p in obs.ped_positions.tolist()
            )  # ValueError with nobody around
        if c.big_crowd and n > 100:
            raise RuntimeError(f"cannot handle {n} pedestrians")
        if c.nan and self.decisions >= 5:
            w = float("nan")
        if c.too_fast:
            v = 2.0 * obs.robot_limits["v_max"]
        if c.noisy:
            w = max(-1.0, min(1.0, w + random.uniform(-0.1, 0.1)))
        if c.slow_s:
            time.sleep(c.slow_s)
        if c.leaky:
            v = min(v, 0.1 * self.decisions % 1.0)
        return v, w
