"""Replay scenes in the simulator: recorded pedestrians follow their tracks exactly and ignore the robot."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from foresight.core.scenarios.loader import load_matrix
from foresight.core.sim.simulator import Simulator

REPO = Path(__file__).resolve().parents[3]

#: frame, id, x, y: ped 1 walks right all window, ped 2 comes and goes, ped 3 has a gap, ped 4 stands
ROWS = (
    [(f, 1, 1 + 0.5 * f / 10, 5.0) for f in range(0, 210, 10)]
    + [(f, 2, 6.0, 1 + 0.3 * (f - 50) / 10) for f in range(50, 130, 10)]
    + [(f, 3, 3.0 + 0.1 * f / 10, 8.0) for f in (*range(0, 50, 10), *range(100, 170, 10))]
    + [(f, 4, 12.0, 9.0) for f in range(0, 210, 10)]
)


def write(path: Path, data) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(data if isinstance(data, str) else yaml.safe_dump(data, sort_keys=False))
    return path


@pytest.fixture
def scene_root(tmp_path: Path) -> Path:
    lines = [f"{f}\t{i}\t{x}\t{y}" for f, i, x, y in sorted(ROWS)]
    write(tmp_path / "data" / "raw" / "all_data" / "mini.txt", "\n".join(lines) + "\n")
    return tmp_path / "data"


def _matrix(tmp_path: Path, root: Path, steps: int = 80, **replay):
    block = {
        "scene": "mini",
        "start_frame": 0,
        "robot_start": [-1.0, -1.0],
        "robot_goal": [-1.5, 10.0],
        "margin": 3.0,
        **replay,
    }
    path = write(
        tmp_path / "m.yaml",
        {
            "scenarios": [
                {"name": "mini_replay", "replay": block, "simulation_config": {"max_episode_steps": steps}}
            ]
        },
    )
    return load_matrix(path, data_roots=lambda name: root)


def _stand(scen, seed: int = 0):
    sim = Simulator()
    obs = [sim.reset(scen, seed)]
    while not sim.done:
        obs.append(sim.step((0.0, 0.0))[0])
    return sim, obs


def test_positions_equal_the_recording_at_every_recorded_instant(tmp_path: Path, scene_root: Path) -> None:
    scen = _matrix(tmp_path, scene_root).scenarios[0]
    sim, _ = _stand(scen)
    tr = sim.trace
    assert tr.steps == 80 and tr.outcome == "timeout"
    ox, oy = scen.replay.offset
    slots = {int(pid): k for k, pid in enumerate(np.unique([r[1] for r in ROWS]))}
    for f, pid, x, y in ROWS:
        step = f // 10 * 4  # 0.4 s annotations, dt 0.1 s
        assert tr.ped_ids[step, slots[pid]] == pid
        assert tr.ped_pos[step, slots[pid]].tolist() == [x - ox, y - oy]
    # between annotations: on the straight line, velocity = the segment's slope
    assert np.allclose(tr.ped_pos[2, slots[1]], [1.25 - ox, 5.0 - oy]) and np.allclose(
        tr.ped_vel[2, slots[1]], [1.25, 0]
    )
    assert np.allclose(
        tr.ped_pos[28, slots[3]], [3.7 - ox, 8.0 - oy]
    )  # frame 70, in the gap 40..100: interpolated


def test_absent_pedestrians_are_empty_slots_and_unseen(tmp_path: Path, scene_root: Path) -> None:
    sim, obs = _stand(_matrix(tmp_path, scene_root).scenarios[0])
    ids = sim.trace.ped_ids
    k2 = 1  # slot of ped 2 (ids sorted)
    assert (ids[:20, k2] == -1).all() and (ids[20:49, k2] == 2).all() and (ids[49:, k2] == -1).all()
    assert (sim.trace.ped_vel[:20, k2] == 0).all()
    assert sorted(obs[0].ped_ids.tolist()) == [1, 3, 4] and sorted(obs[30].ped_ids.tolist()) == [1, 2, 3, 4]
    assert sorted(obs[70].ped_ids.tolist()) == [1, 4] and len(obs[70].ped_positions) == 2


def test_replayed_pedestrians_ignore_the_robot_and_collisions_are_detected(
    tmp_path: Path, scene_root: Path
) -> None:
    # the robot stands on ped 1's path: ped 1 walks into it unchanged, and the collision ends the episode
    scen = _matrix(tmp_path, scene_root, robot_start=[6.0, 5.0], robot_goal=[6.0, -1.0]).scenarios[0]
    sim, _ = _stand(scen)
    tr = sim.trace
    assert tr.outcome == "collision_pedestrian"
    free, _ = _stand(_matrix(tmp_path / "b", scene_root).scenarios[0])
    assert np.array_equal(tr.ped_pos, free.trace.ped_pos[: tr.steps + 1])
    d = np.hypot(*(tr.ped_pos[-1, 0] - tr.robot[-1, :2]))
    assert d <= 1.4 < np.hypot(*(tr.ped_pos[-2, 0] - tr.robot[-2, :2]))


def test_a_pedestrian_who_would_appear_inside_the_robot_is_left_out(tmp_path: Path, scene_root: Path) -> None:
    # ped 2's track begins at (6, 1) at step 20: a robot standing 0.5 m from there would be hit out of thin air
    k2 = 1  # slot of ped 2 (ids sorted)
    sim, obs = _stand(
        _matrix(tmp_path, scene_root, robot_start=[6.0, 1.5], robot_goal=[1.0, -1.5]).scenarios[0]
    )
    tr = sim.trace
    assert tr.outcome == "timeout" and (tr.ped_ids[:, k2] == -1).all()
    assert 2 not in {int(i) for o in obs for i in o.ped_ids} and tr.metadata()["replay_withheld"] == [2]
    # 3.2 m away it appears as recorded, and the others are never touched
    far, _ = _stand(
        _matrix(tmp_path / "b", scene_root, robot_start=[3.0, 0.0], robot_goal=[-0.5, 3.0]).scenarios[0]
    )
    assert (far.trace.ped_ids[20:49, k2] == 2).all() and far.trace.metadata()["replay_withheld"] == []
    others = [k for k in range(tr.ped_ids.shape[1]) if k != k2]
    assert np.array_equal(tr.ped_pos[:, others], far.trace.ped_pos[: tr.steps + 1, others])


def test_replay_is_deterministic(tmp_path: Path, scene_root: Path) -> None:
    scen = _matrix(tmp_path, scene_root).scenarios[0]
    a, _ = _stand(scen, 3)
    b, _ = _stand(scen, 3)
    for name in ("robot", "ped_ids", "ped_pos", "ped_vel"):
        assert np.array_equal(getattr(a.trace, name), getattr(b.trace, name))


def test_stress_replay_episode_follows_the_real_recording(shared_dir: Path) -> None:
    from foresight.core.scenarios.ethucy import read_scene

    m = load_matrix(
        REPO / "configs" / "scenarios" / "stress.yaml", data_roots=lambda n: shared_dir / "reference" / n
    )
    scen = next(
        s for s in m.scenarios if s.scenario.replay is not None and s.scenario.replay.scene == "crowds_zara01"
    )
    sim, _ = _stand(scen)
    tr = sim.trace
    assert tr.steps >= 20  # the selection rule keeps the first 2 s clear of the start
    cfg = scen.scenario.replay
    rows = read_scene(shared_dir / "reference" / "ethucy" / "raw" / "all_data" / "crowds_zara01.txt")
    ox, oy = scen.replay.offset
    checked = 0
    for f, pid, x, y in rows[
        (rows[:, 0] >= cfg.start_frame) & (rows[:, 0] <= cfg.start_frame + tr.steps // 4 * 10)
    ]:
        step = int(f - cfg.start_frame) // 10 * 4
        slot = np.nonzero(tr.ped_ids[step] == pid)[0]
        assert len(slot) == 1 and tr.ped_pos[step, slot[0]].tolist() == [x - ox, y - oy]
        checked += 1
    assert checked > 50


def test_collection_takes_a_replay_scenario(tmp_path: Path, scene_root: Path, monkeypatch) -> None:
    """A replay scenario is an ordinary scenario for every stage: here collection, the data root named through
    FORESIGHT_DATA_ROOTS as a service worker would."""
    from foresight.core.predict.dataset import load_dataset
    from foresight.core.runtime.context import StageContext
    from foresight.core.training.collect import CollectConfig, run_collect

    monkeypatch.setenv("FORESIGHT_DATA_ROOTS", f"minidata={scene_root}")
    bundle = tmp_path / "bundle"
    write(
        bundle / "m.yaml",
        {
            "scenarios": [
                {
                    "name": "mini_replay",
                    "simulation_config": {"max_episode_steps": 80},
                    "replay": {
                        "data_root": "minidata",
                        "scene": "mini",
                        "start_frame": 0,
                        "robot_start": [13.6, 0.0],
                        "robot_goal": [13.6, 10.0],
                        "margin": 3.0,
                    },
                }
            ]
        },
    )
    cfg = CollectConfig(
        matrix="m.yaml", seeds_per_scenario=1, max_steps=60, check_quality=False, val_fraction=0.0
    )
    res = run_collect(cfg, StageContext(workdir=tmp_path / "out", resolve_bundle=lambda ident: bundle))
    ds = load_dataset(tmp_path / "out" / res.dataset)
    assert len(ds) > 10 and ds.meta.episodes[0].scenario == "mini_replay"
    assert (ds.mask.sum(axis=1) >= 2).all()  # recorded pedestrians are in every sample
