import pytest

from foresight.core.errors import ConfigError
from foresight.core.predict.timebase import ETHUCY_TIMEBASE, PLANNER_TIMEBASE, TimeBase


def test_times_and_stride():
    assert list(PLANNER_TIMEBASE.times.round(6))[:3] == [0.2, 0.4, 0.6]
    assert PLANNER_TIMEBASE.stride(0.1) == 2
    assert ETHUCY_TIMEBASE.stride(0.1) == 4


def test_stride_must_be_integer_multiple():
    with pytest.raises(ConfigError, match="integer multiple"):
        TimeBase(0.25, 4, 8).stride(0.1)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(dt=0, history=5, horizon=12),
        dict(dt=0.2, history=0, horizon=12),
        dict(dt=0.2, history=5, horizon=2.5),
        dict(dt=float("nan"), history=5, horizon=1),
    ],
)
def test_invalid_values_rejected(kwargs):
    with pytest.raises(ConfigError):
        TimeBase(**kwargs)


def test_mismatch_error_names_both():
    with pytest.raises(ConfigError, match=r"dt=0.4s H=8 T=12.*dt=0.2s H=5 T=12"):
        PLANNER_TIMEBASE.require_same(ETHUCY_TIMEBASE, "checkpoint", source="m.pt")
    PLANNER_TIMEBASE.require_same(TimeBase(0.2 + 1e-9, 5, 12))


def test_dict_round_trip_and_bad_dict():
    assert TimeBase.from_dict(PLANNER_TIMEBASE.to_dict()) == PLANNER_TIMEBASE
    with pytest.raises(ConfigError, match="f.json"):
        TimeBase.from_dict({"dt": 0.2, "history": 5}, source="f.json")
