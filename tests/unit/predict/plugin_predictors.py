"""Predictor plug-ins for the tests: good ones and each way of breaking the forecast contract."""

from __future__ import annotations

import numpy as np

PLANNER_TB = {"dt": 0.2, "history": 5, "horizon": 12}


class StraightOn:
    """Constant velocity, two modes (the second 20 % faster), pedestrian frame: a well-behaved plug-in."""

    name = "straight_on"
    predictor_api = 1
    timebase = PLANNER_TB
    frame = "pedestrian"
    modes = 2

    def predict(self, window):
        n, T, dt = len(window.ped_ids), self.timebase["horizon"], window.dt
        d = window.history[:, -1] - window.history[:, -2]
        speed = np.where(window.valid[:, -2], np.hypot(d[:, 0], d[:, 1]) / dt, 0.0)
        t = dt * np.arange(1, T + 1)
        modes = np.zeros((n, 2, T, 2))
        modes[:, 0, :, 0] = speed[:, None] * t
        modes[:, 1, :, 0] = 1.2 * speed[:, None] * t
        return {"modes": modes, "weights": np.tile([0.7, 0.3], (n, 1)), "sigma": np.full((n, 2, T), 0.1)}


class Broken(StraightOn):
    """Breaks the contract as ``how`` says."""

    def __init__(self, how: str):
        self.how = how
        self.name = f"broken_{how}"

    def predict(self, window):
        out = super().predict(window)
        if self.how == "nan":
            out["modes"][:] = np.nan
        elif self.how == "shape":
            out["modes"] = out["modes"][:, :, :-1]
        elif self.how == "modes":
            out = {k: v[:, :1] for k, v in out.items()}
            out["weights"] = out["weights"] / out["weights"]
        elif self.how == "raise":
            raise RuntimeError("model weights missing")
        return out


def nan_predictor():
    return Broken("nan")


def too_few_modes():
    return Broken("modes")
