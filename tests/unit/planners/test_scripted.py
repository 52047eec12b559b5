"""The scripted planner: a fixed plan (via points, a stand until a release time, then on), driven with the robot's
own limits; what a witness is made of."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.planners.registry import make_planner
from foresight.core.planners.scripted import Scripted, ScriptedConfig


def _obs(t: float, pose: tuple[float, float, float], goal=(10.0, 0.0), **limits: float) -> SimpleNamespace:
    return SimpleNamespace(
        robot_pose=np.array(pose),
        time=t,
        goal=np.array(goal),
        robot_limits={"v_max": 2.0, "w_max": 1.0, **limits},
    )


def test_it_stands_at_its_hold_until_the_release_then_drives_on() -> None:
    driver = Scripted(ScriptedConfig(hold=(0.0, 0.0), release_s=5.0))
    driver.reset(None)
    assert driver.plan(_obs(4.9, (0.1, 0.0, 0.0))) == (0.0, 0.0)  # at the hold before its release: stands
    assert driver.plan(_obs(5.0, (0.1, 0.0, 0.0))) == (
        2.0,
        0.0,
    )  # released: full speed at the goal straight ahead
    v, w = driver.plan(_obs(5.1, (0.1, 0.0, np.pi / 2)))
    assert v < 1e-9 and w == -1.0  # facing away by 90 degrees: turns at the limit without driving
    vx, vy = driver.plan(_obs(6.0, (0.0, 0.0, 0.0), goal=(0.0, -10.0), holonomic=1.0))
    assert (
        abs(vx) < 1e-12 and vy == -2.0
    )  # a holonomic robot is sent a world-frame velocity straight at the goal


def test_it_drives_its_points_in_order_and_passes_a_hold_reached_after_its_release() -> None:
    driver = Scripted(ScriptedConfig(via=((0.0, 5.0),), hold=(5.0, 5.0), release_s=1.0, after=((5.0, 0.0),)))
    driver.reset(None)
    v, w = driver.plan(_obs(0.0, (0.0, 0.0, np.pi / 2)))
    assert (v, w) == (2.0, 0.0)  # the via point straight ahead
    assert driver.plan(_obs(3.0, (0.0, 5.0, 0.0))) == (
        2.0,
        0.0,
    )  # via reached: on at the hold, straight ahead
    v, w = driver.plan(_obs(5.0, (5.0, 5.0, 0.0)))
    assert v < 1e-9 and w == -1.0  # hold reached after its release: on to the after point, to the right
    assert driver.diagnostics == {"stop": 2}


def test_it_is_a_registered_planner_and_says_what_it_does() -> None:
    plan = {"via": [[26.51, 15.38]], "hold": [25.525, 15.012], "release_s": 32, "after": [[18.7, 12.46]]}
    planner = make_planner("scripted", plan)
    assert isinstance(planner, Scripted) and planner.config.release_s == 32.0
    assert (
        planner.config.describe()
        == "via (26.51, 15.38); wait at (25.52, 15.01) until 32 s; then (18.70, 12.46)"
    )
    assert ScriptedConfig().describe() == "straight at the goal"
    with pytest.raises(ConfigError) as bad:
        make_planner("scripted", {"hold": [1.0]})
    assert bad.value.item.startswith("scripted.hold")
    with pytest.raises(ConfigError) as late:
        make_planner("scripted", {"release_s": -1})
    assert late.value.item == "scripted.release_s"
    with pytest.raises(ConfigError) as nan:
        make_planner("scripted", {"hold": [float("nan"), 1.0]})
    assert nan.value.item.startswith("scripted.hold")
    with pytest.raises(ConfigError) as many:
        make_planner("scripted", {"via": [[0.0, 0.0]] * 1001})
    assert many.value.item == "scripted.via"
