"""Constant velocity with sampled heading noise: the field's simple K-sample baseline, as a predictor plug-in.

Each pedestrian keeps its last observed speed (backward difference of its last two observed positions); mode 0
keeps its heading too, modes 1..K-1 turn it by an angle drawn from N(0, heading_std). Every mode has weight 1/K, so
the most likely mode (best-of-1) is plain constant velocity. Each mode's spread grows with its age,
sqrt(sigma0^2 + (sigma_v t)^2). Plain numpy, no Foresight import: it answers with the forecast message (a dict).
"""

import math

import numpy as np


class ConstantVelocityHeadingNoise:
    name = "cv_noise"
    predictor_api = 1
    #: ETH/UCY's protocol (0.4 s, 8 observed, 12 predicted); the planner resamples it onto its own step
    timebase = {"dt": 0.4, "history": 8, "horizon": 12}
    frame = "world"

    def __init__(self, modes=20, heading_std_deg=25.0, sigma0=0.05, sigma_v=0.25, seed=0, timebase=None):
        self.modes = int(modes)
        self.timebase = dict(timebase or self.timebase)
        self.heading_std = math.radians(heading_std_deg)
        self.sigma0, self.sigma_v, self.seed = sigma0, sigma_v, seed
        self._rng = np.random.default_rng(seed)

    def reset(self):
        self._rng = np.random.default_rng(self.seed)

    def predict(self, window):
        hist, valid, dt = np.asarray(window.history, float), np.asarray(window.valid, bool), window.dt
        n, K, T = len(hist), self.modes, self.timebase["horizon"]
        cur = hist[:, -1]
        vel = np.zeros((n, 2))
        if hist.shape[1] > 1:
            ok = valid[:, -1] & valid[:, -2]
            vel[ok] = (cur[ok] - hist[ok, -2]) / dt
        angle = self._rng.normal(0.0, self.heading_std, (n, K))
        angle[:, 0] = 0.0
        c, s = np.cos(angle), np.sin(angle)
        v = np.stack(
            [c * vel[:, None, 0] - s * vel[:, None, 1], s * vel[:, None, 0] + c * vel[:, None, 1]], -1
        )
        t = dt * np.arange(1, T + 1)
        modes = cur[:, None, None, :] + t[None, None, :, None] * v[:, :, None, :]  # (N, K, T, 2)
        sigma = np.broadcast_to(np.sqrt(self.sigma0**2 + (self.sigma_v * t) ** 2), (n, K, T))
        return {"modes": modes, "weights": np.full((n, K), 1.0 / K), "sigma": sigma}


def planner_six():
    """Six modes on the planner's own time base (0.2 s, 5 observed, 12 ahead): the decision-time benchmark's."""
    return ConstantVelocityHeadingNoise(modes=6, timebase={"dt": 0.2, "history": 5, "horizon": 12})
