"""Config models of the ORCA pedestrian model and of the generated crowds of the field's benchmarks (CrowdNav).

``OrcaPedestrians`` is ``simulation_config.orca`` (read where ``pedestrian_model: orca``); ``CrowdGenerator`` is a
scenario's ``crowd_generator``: humans and the robot's start and goal drawn by CrowdNav's rules instead of the
map's zones and routes. The rules and parameters are facts of the cited repositories (see
``configs/scenarios/crowdnav/``); the code is ours (``core.sim.generated_crowd``).
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from foresight.core.maps.model import Point


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class OrcaPedestrians(_Strict):
    """Each pedestrian an ORCA agent (RVO2): CrowdNav's human policy. Defaults are CrowdNav's."""

    neighbor_dist: float = Field(default=10.0, gt=0)  #: [m] centre distance of the neighbours considered
    max_neighbors: int = Field(default=10, ge=1, le=1000)
    time_horizon: float = Field(default=5.0, gt=0)  #: [s] against other agents
    time_horizon_obst: float = Field(default=5.0, gt=0)  #: [s] against static obstacles
    safety_space: float = Field(default=0.0, ge=0)  #: added, with 0.01 m, to every agent's radius [m]
    robot_visible: bool = False  #: False = the pedestrians never react to the robot


class CrowdGenerator(_Strict):
    """Humans and the robot's start and goal drawn by CrowdNav's rules, around ``centre`` (map coordinates).

    The episode seed seeds numpy's legacy generator (``numpy.random.RandomState(seed)``, an object of the episode,
    never the global state) and the draws follow CrowdNav's order, so seed s is CrowdNav's test case drawn with
    ``np.random.seed(s)``.
    """

    rule: Literal["circle_crossing", "square_crossing"]
    human_num: int = Field(ge=0, le=200)
    centre: Point  #: map coordinates of the generator's origin [m]
    circle_radius: float = Field(default=4.0, gt=0)  #: [m]
    square_width: float = Field(default=10.0, gt=0)  #: [m]
    #: circle-crossing start noise per axis: ``symmetric`` (U - 0.5) x the human's speed (CrowdNav), ``positive``
    #: U x 2 m (CrowdNav++'s variable-number environment)
    start_noise: Literal["symmetric", "positive"] = "symmetric"
    discomfort_dist: float = Field(default=0.2, ge=0)  #: kept between surfaces when placing humans [m]
    human_speed: float = Field(default=1.0, gt=0)  #: preferred speed (the ORCA agent's max speed) [m/s]
    #: ``fixed``: the robot from (0, -circle_radius) to (0, circle_radius) facing +y (CrowdNav); ``random``: start
    #: and goal uniform in [-arena_size, arena_size]^2, at least ``robot_min_travel`` apart (CrowdNav++)
    robot_rule: Literal["fixed", "random"] = "fixed"
    arena_size: float = Field(default=6.0, gt=0)  #: [m]
    robot_min_travel: float = Field(default=8.0, ge=0)  #: [m]
    randomize_attributes: bool = False  #: each human's speed and radius drawn from the ranges below
    speed_range: tuple[float, float] = (0.5, 1.5)  #: [m/s]
    radius_range: tuple[float, float] = (0.3, 0.5)  #: [m]
    goal_change_interval_s: float = Field(default=5.0, gt=0)  #: [s] between chances of a new goal
    goal_change_chance: float = Field(default=0.0, ge=0, le=1)  #: per human and chance, before it arrives
    #: a human within its radius of its goal: ``stay`` there (CrowdNav), ``respawn`` as a new circle-crossing human
    #: (CrowdNav++ with a holonomic robot), or walk to a ``new_goal`` on the circle
    at_goal: Literal["stay", "respawn", "new_goal"] = "stay"

    @model_validator(mode="after")
    def _ranges(self) -> CrowdGenerator:
        for name in ("speed_range", "radius_range"):
            lo, hi = getattr(self, name)
            if not 0 < lo <= hi:
                raise ValueError(f"{name} must be [low, high] with 0 < low <= high (got [{lo:g}, {hi:g}])")
        if self.rule == "square_crossing" and self.at_goal == "respawn":
            raise ValueError("at_goal: respawn is a circle-crossing rule")
        return self
