"""Trajectory prediction: time base, feature extraction, datasets, constant velocity, forecasters.

Everything here imports without torch; the learned model and its checkpoints live in ``core.predict.nn``.

Map of the package (one concept per module):
- ``timebase``: TimeBase(dt, H, T); planner default 0.2 s, H = 5, T = 12; ETH/UCY 0.4 s, 8, 12.
- ``features``: THE feature extraction (Window -> Features), used by collection and by the planner.
- ``history``: live per-pedestrian histories from Observations (planner side).
- ``samples``: training samples from simulator traces, by true pedestrian ids.
- ``dataset`` / ``quality`` / ``mixing``: the .npz + metadata format, summary and degenerate-data
  checks, episode-level split, base + hard-case mix (oversampling after the split).
- ``ethucy``: ETH/UCY fold import (focal-pedestrian frame) with the leakage rules.
- ``predictor``: the Predictor protocol and constant velocity; ``metrics``: ADE/FDE over target_mask.
- ``forecaster``: Forecast, ConstantVelocityForecaster, LearnedForecaster (what the planner calls).

Training (collection, the training config, the closed-loop proxy, ``run_train``, the ETH/UCY benchmark) runs
evaluations, so it lives above evaluation in ``core.training``; ``ethucy.run_import_ethucy`` stays here.
"""
