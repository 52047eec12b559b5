"""Hand-built maps and scenarios for simulator tests (no shared data needed)."""

from __future__ import annotations

from foresight.core.maps.model import MapDef, Route, SinglePedestrian, Zone
from foresight.core.scenarios.model import ResolvedScenario, RobotConfig, Scenario, SimulationConfig


def open_map(
    *,
    width: float = 40.0,
    height: float = 30.0,
    obstacles: tuple = (),
    singles: tuple = (),
    robot_start: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0),
    robot_goal: tuple = (37.0, 1.0),
    ped_routes: tuple = (),
    ped_spawn: tuple = (),
    ped_goal: tuple = (),
    crowded: tuple = (),
) -> MapDef:
    """A map whose robot spawns in the rect ``robot_start`` (x, y, w, h) and drives right along its y."""
    x, y, w, h = robot_start
    sy = y + h / 2
    gx, gy = robot_goal
    return MapDef(
        name="test_map",
        width=width,
        height=height,
        obstacles=obstacles,
        robot_spawn_zones=(Zone.from_rect(x, y, w, h),),
        robot_goal_zones=(Zone.from_rect(gx, gy, 1.0, 1.0),),
        robot_routes=(Route(spawn_id=0, goal_id=0, waypoints=((x + w / 2, sy), (gx + 0.5, gy + 0.5))),),
        ped_spawn_zones=ped_spawn,
        ped_goal_zones=ped_goal,
        ped_routes=ped_routes,
        ped_crowded_zones=crowded,
        single_pedestrians=singles,
    )


def scenario(
    map_def: MapDef, name: str = "test", robot: RobotConfig | None = None, **sim
) -> ResolvedScenario:
    cfg = SimulationConfig(**{"ped_density": 0.0, **sim})
    return ResolvedScenario(
        scenario=Scenario(
            name=name, map_id=map_def.name, simulation_config=cfg, robot_config=robot or RobotConfig()
        ),
        map=map_def,
    )


def walker(pid: str, start, goal=None, speed: float = 1.0, **kw) -> SinglePedestrian:
    return SinglePedestrian(id=pid, start=start, goal=goal, speed_m_s=speed, **kw)


def street_map(density_routes: bool = True) -> MapDef:
    """A 40 x 20 street with a block obstacle, a two-way pedestrian route and a crowded square."""
    return MapDef(
        name="street",
        width=40,
        height=20,
        obstacles=(((14, 0), (20, 0), (20, 4), (14, 4)),),
        robot_spawn_zones=(Zone.from_rect(1, 8, 3, 4),),
        robot_goal_zones=(Zone.from_rect(35, 8, 3, 4),),
        robot_routes=(Route(spawn_id=0, goal_id=0, waypoints=((3, 10), (36, 10))),),
        ped_spawn_zones=(Zone.from_rect(2, 5, 3, 3), Zone.from_rect(34, 12, 3, 3)),
        ped_goal_zones=(Zone.from_rect(34, 12, 3, 3), Zone.from_rect(2, 5, 3, 3)),
        ped_routes=(
            Route(spawn_id=0, goal_id=0, waypoints=((3, 6), (20, 7), (35, 13))),
            Route(spawn_id=1, goal_id=1, waypoints=((35, 13), (20, 14), (3, 6))),
        ),
        ped_crowded_zones=(Zone.from_rect(24, 2, 8, 5),),
    )
