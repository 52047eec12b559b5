"""A user's planner as a researcher writes it (no Foresight imports): the in-process route of the tests."""

import math

from pydantic import BaseModel, ConfigDict


class CautiousConfig(BaseModel):
    model_config = ConfigDict(extra="forbid")

    speed: float = 0.9


class Cautious:
    """Head for the waypoint at ``speed``, stop for anyone within 2.5 m ahead."""

    name = "cautious"
    config_model = CautiousConfig

    def __init__(self, config: CautiousConfig):
        self.speed = config.speed
        self.diagnostics = None

    def reset(self, info) -> None:  # noqa: ANN001
        pass

    def plan(self, obs) -> tuple[float, float]:  # noqa: ANN001
        x, y, heading = obs.robot_pose.tolist()
        wx, wy = obs.waypoint.tolist()
        error = (math.atan2(wy - y, wx - x) - heading + math.pi) % (2 * math.pi) - math.pi
        blocked = any(
            math.hypot(px - x, py - y) < 2.5
            and (px - x) * math.cos(heading) + (py - y) * math.sin(heading) > 0
            for px, py in obs.ped_positions.tolist()
        )
        return (0.0 if blocked else self.speed * max(0.0, math.cos(error))), max(-1.0, min(1.0, 1.5 * error))


def broken_factory():  # noqa: ANN201 - a factory whose planner raises on its third step
    class Broken(Cautious):
        def plan(self, obs):  # noqa: ANN001, ANN202
            if obs.step == 2:
                raise RuntimeError("boom at step 2")
            return super().plan(obs)

    return Broken(CautiousConfig())
