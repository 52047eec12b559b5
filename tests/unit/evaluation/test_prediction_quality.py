"""In-loop predictor error: logged forecasts against the trace's true pedestrian positions."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.evaluation.episode import prediction_quality

from .traces import DT, make_trace, still, straight


class _Trace:
    def __init__(self, tr, steps):
        self.__dict__.update(tr.__dict__)
        self.steps = steps


TIMES = np.array([0.2, 0.4, 0.6])


def _forecast(tr, step: int, offset: float, times=TIMES):
    ids = tr.ped_ids[step]
    pos = tr.ped_pos[step][:, None, :] + tr.ped_vel[step][:, None, :] * times[None, :, None] + [offset, 0.0]
    return step, ids.copy(), pos, times


def test_constant_velocity_forecast_of_constant_velocity_walkers_is_exact() -> None:
    base = make_trace(still((0, 0), 20), [straight(5.0, -1.0, 20), still((3.0, 3.0), 20)])
    tr = _Trace(base, 20)
    q, per_ped = prediction_quality(tr, [_forecast(tr, s, 0.0) for s in (0, 5, 10)], DT)
    assert q.ade == pytest.approx(0.0, abs=1e-9) and q.fde == pytest.approx(0.0, abs=1e-9)
    assert q.samples == 3 * 2 * 3 and set(per_ped) == {0, 1}


def test_offset_forecast_and_horizon_past_the_end() -> None:
    tr = _Trace(make_trace(still((0, 0), 20), [still((3.0, 3.0), 20)]), 20)
    q, per_ped = prediction_quality(tr, [_forecast(tr, 0, 0.5), _forecast(tr, 18, 0.5)], DT)
    assert q.ade == pytest.approx(0.5) and per_ped == {0: pytest.approx(0.5)}
    assert q.samples == 3 + 1  # at step 18 only the 0.2 s point lies inside the episode
    assert q.fde == pytest.approx(0.5)  # only complete forecasts count for FDE


def test_respawned_pedestrian_is_not_matched() -> None:
    base = make_trace(still((0, 0), 20), [still((3.0, 3.0), 20)])
    base.ped_ids[4:, 0] = 7  # slot 0 holds a new pedestrian from step 4 on
    tr = _Trace(base, 20)
    q, _ = prediction_quality(tr, [_forecast(tr, 0, 0.0)], DT)
    assert q.samples == 1  # rows 2, 4, 6: from row 4 on the slot holds pedestrian 7 -> only row 2 counts
