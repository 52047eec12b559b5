"""The time base a dataset and every model trained on it declare: step dt, history H, horizon T.

A model serves only its own time base; a mismatch is an error, never a silent resampling. The
simulator runs at its own dt (0.1 s); collection and the forecasters sample it every
``stride(sim_dt)`` steps, which requires the time base dt to be an integer multiple of it.

Planner default (:data:`PLANNER_TIMEBASE`): dt 0.2 s, H = 5 (0.8 s incl. the current step),
T = 12 (2.4 s ahead). 2.4 s covers a crossing pedestrian at 1.3 m/s closing ~3 m, which is the
robot's braking-plus-avoidance range at ~1 m/s; 0.2 s steps match the planner's rollout step, so
predicted and rolled-out positions are compared at the same instants. 0.8 s of history is enough
for a velocity and a turn rate and keeps new (respawned) pedestrians usable after 4 steps.
ETH/UCY (:data:`ETHUCY_TIMEBASE`): 0.4 s, H = 8, T = 12 (the benchmark protocol).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from foresight.core.errors import ConfigError

_TOL = 1e-6


@dataclass(frozen=True)
class TimeBase:
    dt: float  #: step between history/forecast samples [s]
    history: int  #: H, observed steps including the current one
    horizon: int  #: T, predicted future steps

    def __post_init__(self) -> None:
        if not (isinstance(self.dt, int | float) and np.isfinite(self.dt) and 0 < self.dt <= 10):
            raise ConfigError(f"dt must be a finite number in (0, 10] s, got {self.dt!r}", item="timebase.dt")
        for name in ("history", "horizon"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or not 1 <= value <= 200:
                raise ConfigError(
                    f"{name} must be an integer in [1, 200], got {value!r}", item=f"timebase.{name}"
                )
        object.__setattr__(self, "dt", float(self.dt))
        object.__setattr__(self, "history", int(self.history))
        object.__setattr__(self, "horizon", int(self.horizon))

    @property
    def times(self) -> np.ndarray:
        """(T,) seconds ahead of the current step of each forecast step: dt, 2 dt, ..., T dt."""
        return self.dt * np.arange(1, self.horizon + 1, dtype=np.float64)

    def stride(self, sim_dt: float) -> int:
        """Simulator steps per time-base step; the time base dt must be an integer multiple of ``sim_dt``."""
        if not sim_dt > 0:
            raise ConfigError(f"simulator dt must be > 0, got {sim_dt!r}", item="dt")
        ratio = self.dt / sim_dt
        k = round(ratio)
        if k < 1 or abs(ratio - k) > 1e-6 * max(1.0, ratio):
            raise ConfigError(
                f"time base dt {self.dt} s is not an integer multiple of the simulator dt {sim_dt} s",
                item="timebase.dt",
            )
        return k

    def same_as(self, other: TimeBase) -> bool:
        return (
            abs(self.dt - other.dt) <= _TOL
            and self.history == other.history
            and self.horizon == other.horizon
        )

    def require_same(self, other: TimeBase, what: str = "model", source: str | None = None) -> None:
        """Raise a ConfigError naming both time bases when ``other`` differs from this one."""
        if not self.same_as(other):
            raise ConfigError(
                f"time base mismatch: {what} declares {other.describe()} but {self.describe()} is required",
                source=source,
                item="timebase",
            )

    def describe(self) -> str:
        return f"dt={self.dt:g}s H={self.history} T={self.horizon}"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: Any, source: str | None = None) -> TimeBase:
        if not isinstance(data, dict) or set(data) != {"dt", "history", "horizon"}:
            raise ConfigError(
                f"time base must be a mapping with dt, history, horizon; got {data!r}",
                source=source,
                item="timebase",
            )
        try:
            return cls(dt=data["dt"], history=data["history"], horizon=data["horizon"])
        except ConfigError as exc:
            raise ConfigError(exc.detail, source=source, item=exc.item) from None


PLANNER_TIMEBASE = TimeBase(dt=0.2, history=5, horizon=12)
ETHUCY_TIMEBASE = TimeBase(dt=0.4, history=8, horizon=12)
