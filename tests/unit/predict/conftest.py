import numpy as np
import pytest
import torch

from foresight.core.predict.dataset import DatasetMeta, EpisodeRecord, save_dataset
from foresight.core.predict.mixing import assign_splits, dataset_from_episodes
from foresight.core.predict.samples import samples_from_trace
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from tests.unit.predict.helpers import make_trace


@pytest.fixture(autouse=True)
def _one_torch_thread():
    torch.set_num_threads(1)


def curving_episode(seed: int, steps: int = 80):
    """Pedestrians on circular arcs (constant speed and turn rate): learnable, not constant velocity."""
    rng = np.random.default_rng(seed)
    n = 5
    t = np.arange(steps + 1) * 0.1
    centre = rng.uniform(-4, 4, size=(n, 2))
    radius = rng.uniform(2, 4, size=n)
    omega = rng.choice([-1, 1], size=n) * rng.uniform(0.3, 0.5, size=n)
    phase = rng.uniform(0, 2 * np.pi, size=n)
    ang = phase[None] + omega[None] * t[:, None]
    pos = centre[None] + radius[None, :, None] * np.stack([np.cos(ang), np.sin(ang)], axis=-1)
    robot = np.zeros((steps + 1, 5))
    robot[:, 0] = -6 + 0.5 * t
    robot[:, 3] = 0.5
    ids = np.tile(np.arange(n, dtype=np.int64), (steps + 1, 1))
    return make_trace(robot, ids, pos), np.tile([[8.0, 0.0]], (steps + 1, 1))


def write_curving_dataset(path):
    """A small simulator-like dataset on the planner time base, saved at ``path``; returns the path."""
    n = 16
    splits = assign_splits(n, 0.25, 0)
    eps = []
    for i in range(n):
        trace, wps = curving_episode(i)
        eps.append(
            (EpisodeRecord("arcs", i, splits[i]), samples_from_trace(trace, PLANNER_TIMEBASE, 6, wps, 1))
        )
    ds = dataset_from_episodes(
        eps, DatasetMeta(PLANNER_TIMEBASE, 6, "robot", "sim", [], generator={"arcs": n})
    )
    save_dataset(ds, path)
    return path


@pytest.fixture(scope="session")
def curving_dataset(tmp_path_factory):
    """:func:`write_curving_dataset` in a session folder."""
    return write_curving_dataset(tmp_path_factory.mktemp("data") / "arcs.npz")
