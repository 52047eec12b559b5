"""A toy planner plugin: head for the waypoint, slow down near pedestrians ahead."""

import math

from pydantic import BaseModel, ConfigDict, Field


class ToyConfig(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    speed: float = Field(default=1.0, gt=0, le=2)  #: cruise speed [m/s]
    caution_distance: float = Field(default=2.5, ge=0)  #: slow down for pedestrians ahead within this [m]
    cautious_speed: float = Field(default=0.3, ge=0)  #: [m/s]


class ToyPlanner:
    """Goal seeking with a speed cap near pedestrians ahead (a plugin of the foresight.planners group)."""

    name = "toy"
    config_model = ToyConfig
    planner_api = 1

    def __init__(self, config: ToyConfig):
        self.config = config
        self.diagnostics = None

    def reset(self, info) -> None:  # noqa: ANN001 - an EpisodeInfo
        self.diagnostics = None

    def plan(self, obs) -> tuple[float, float]:  # noqa: ANN001 - an Observation
        c = self.config
        x, y, heading = (float(a) for a in obs.robot_pose)
        wx, wy = (float(a) for a in obs.waypoint)
        error = (math.atan2(wy - y, wx - x) - heading + math.pi) % (2 * math.pi) - math.pi
        v = c.speed * max(0.0, 1.0 - abs(error) / (math.pi / 2))
        for px, py in obs.ped_positions.tolist():
            dx, dy = px - x, py - y
            if (
                dx * math.cos(heading) + dy * math.sin(heading) > 0
                and math.hypot(dx, dy) < c.caution_distance
            ):
                v = min(v, c.cautious_speed)
        self.diagnostics = {"heading_error": error}
        return v, max(-1.0, min(1.0, 1.5 * error))
