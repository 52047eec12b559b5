"""Hand-built maps, episode infos and observations for planner tests (no simulator needed)."""

from __future__ import annotations

import numpy as np

from foresight.core.maps.model import MapDef, Route, Zone
from foresight.core.scenarios.model import ResolvedScenario, Scenario
from foresight.core.sim.geometry import StaticMap
from foresight.core.sim.observation import Observation
from foresight.core.sim.planner import EpisodeInfo
from foresight.core.sim.robot import RobotLimits


def corridor_map(obstacles: tuple = (), width: float = 30.0, height: float = 20.0) -> MapDef:
    """An open 30 x 20 m map whose robot route runs left to right along y = 10."""
    return MapDef(
        name="test",
        width=width,
        height=height,
        obstacles=obstacles,
        robot_spawn_zones=(Zone.from_rect(1, 9, 2, 2),),
        robot_goal_zones=(Zone.from_rect(26, 9, 2, 2),),
        robot_routes=(Route(spawn_id=0, goal_id=0, waypoints=((2.0, 10.0), (27.0, 10.0))),),
    )


def info_for(map_def: MapDef, dt: float = 0.1) -> EpisodeInfo:
    scen = ResolvedScenario(scenario=Scenario(name="test", map_id="test"), map=map_def)
    return EpisodeInfo(scenario=scen, seed=0, dt=dt, robot_radius=1.0, ped_radius=0.4)


def observation(
    map_def: MapDef,
    pose=(5.0, 10.0, 0.0),
    velocity=(1.0, 0.0),
    route=((27.0, 10.0),),
    peds=(),
    ped_vels=None,
    step: int = 0,
    static: StaticMap | None = None,
) -> Observation:
    """An observation of the reference robot (r = 1.0 m, 2 m/s, 1 rad/s) with pedestrians ``peds`` (N, 2)."""
    route_arr = np.asarray(route, dtype=float).reshape(-1, 2)
    p = np.asarray(peds, dtype=float).reshape(-1, 2)
    v = np.zeros_like(p) if ped_vels is None else np.asarray(ped_vels, dtype=float).reshape(-1, 2)
    return Observation(
        step=step,
        time=step * 0.1,
        dt=0.1,
        robot_pose=np.asarray(pose, dtype=float),
        robot_velocity=np.asarray(velocity, dtype=float),
        robot_radius=1.0,
        waypoint=route_arr[0],
        goal=route_arr[-1],
        route=route_arr,
        goal_tolerance=2.0,
        ped_ids=np.arange(len(p), dtype=np.int64),
        ped_positions=p,
        ped_velocities=v,
        ped_radius=0.4,
        static=static or StaticMap(map_def),
        robot_limits=RobotLimits().as_dict(),
    )
