"""Trajectory prediction: time base, feature extraction, datasets, constant velocity, forecasters.

Everything here imports without torch; the learned model, its training and checkpoints live in
``core.predict.nn``.
"""
