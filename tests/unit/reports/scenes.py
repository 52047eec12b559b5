"""A small map and a hand-built trace (robot crossing two pedestrians, a collision at step 40)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from foresight.core.maps.model import MapDef, Route, Zone

STEPS = 60


@dataclass
class FakeTrace:
    robot: np.ndarray
    command: np.ndarray
    ped_ids: np.ndarray
    ped_pos: np.ndarray
    ped_vel: np.ndarray
    dt: float = 0.1
    steps: int = STEPS


def small_map() -> MapDef:
    return MapDef(
        name="report_test",
        width=30,
        height=20,
        obstacles=(((12.0, 0.0), (18.0, 0.0), (18.0, 6.0), (12.0, 6.0)),),
        robot_spawn_zones=(Zone.from_rect(1, 9, 2, 2),),
        robot_goal_zones=(Zone.from_rect(27, 9, 2, 2),),
        robot_routes=(Route(spawn_id=0, goal_id=0, waypoints=((2, 10), (28, 10))),),
        ped_spawn_zones=(Zone.from_rect(14, 17, 2, 2),),
        ped_goal_zones=(Zone.from_rect(14, 7, 2, 2),),
        ped_routes=(Route(spawn_id=0, goal_id=0, waypoints=((15, 18), (15, 8))),),
    )


def trace(steps: int = STEPS) -> FakeTrace:
    t = np.arange(steps + 1)
    robot = np.column_stack(
        [
            2 + 0.3 * t,
            np.full(steps + 1, 10.0),
            np.zeros(steps + 1),
            np.full(steps + 1, 3.0),
            np.zeros(steps + 1),
        ]
    )
    ids = np.tile(np.array([0, 1], dtype=np.int64), (steps + 1, 1))
    ids[30:, 1] = 2  # respawned pedestrian: new id
    pos = np.zeros((steps + 1, 2, 2))
    pos[:, 0] = np.column_stack([np.full(steps + 1, 14.0), 18 - 0.2 * t])
    pos[:, 1] = np.column_stack([20 - 0.1 * t, np.full(steps + 1, 12.0)])
    vel = np.zeros_like(pos)
    return FakeTrace(robot=robot, command=robot[:-1, 3:5], ped_ids=ids, ped_pos=pos, ped_vel=vel, steps=steps)


def predictions(steps: int = STEPS, every: int = 5) -> list[tuple[int, np.ndarray, np.ndarray, np.ndarray]]:
    """The evaluation's StepLog.predictions format: (step, ids, positions (M, H, 2), times (H,))."""
    tr = trace(steps)
    times = 0.4 * np.arange(1, 9)
    out = []
    for s in range(0, steps, every):
        ids = tr.ped_ids[s]
        future = tr.ped_pos[s][:, None, :] + np.array([0.0, -0.5])[None, None, :] * times[None, :, None]
        out.append((s, ids.copy(), future, times))
    return out
