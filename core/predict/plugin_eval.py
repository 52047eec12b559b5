"""A predictor plug-in offline: one observation window per dataset sample, its forecasts gathered for scoring.

Each sample's window is rebuilt from its features (positions and valid flags of every active slot, in the sample's
ego frame, which serves as the world: for ETH/UCY the focal pedestrian's frame), so a plug-in sees exactly what the
built-in network sees, never a future position. The plug-in's declared time base must be the dataset's.
"""

from __future__ import annotations

import numpy as np

from foresight.core.predict.features import STEP_CHANNELS
from foresight.core.predict.forecast import PredictorError
from foresight.core.predict.plugin import ObservationWindow, PluginForecaster, forecast_from


def sample_window(state: np.ndarray, mask: np.ndarray, history: int, dt: float) -> ObservationWindow:
    """The observation window of one sample: features (N, F) and slot mask (N,); slot indices are the ids."""
    slots = np.flatnonzero(mask > 0)
    C = len(STEP_CHANNELS)
    cols = np.arange(history) * C
    px, py, ok = (STEP_CHANNELS.index(c) for c in ("px", "py", "valid"))
    f = state[slots].astype(np.float64)
    hist = np.stack([f[:, cols + px], f[:, cols + py]], axis=-1)  # (n, H, 2)
    valid = f[:, cols + ok] > 0.5
    return ObservationWindow(
        time=0.0,
        dt=dt,
        ped_ids=slots.astype(np.int64),
        history=hist,
        valid=valid,
        robot_pose=np.zeros(3),
        robot_velocity=np.zeros(2),
    )


def plugin_forecasts(
    forecaster: PluginForecaster, state: np.ndarray, mask: np.ndarray, timebase
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Modes (S, N, K, T, 2), weights (S, N, K) and spread (S, N, K, T[, 2, 2]) of a plug-in over samples
    ``state`` (S, N, F), ``mask`` (S, N); empty slots hold zeros (weights 1/K)."""
    decl, who = forecaster.declared, forecaster.who
    if not decl.timebase.same_as(timebase):
        raise PredictorError(
            who,
            f"declares {decl.timebase.describe()} but the data is on {timebase.describe()} (wrong time base)",
        )
    S, N = mask.shape
    T = timebase.horizon
    modes = weights = spread = None
    forecaster.reset()
    for s in range(S):
        window = sample_window(state[s], mask[s], timebase.history, timebase.dt)
        try:
            reply = forecaster.predictor.predict(window)
        except PredictorError:
            raise
        except Exception as exc:  # noqa: BLE001 - the plug-in's own failure, named
            raise PredictorError(who, f"raised {type(exc).__name__}: {exc}") from exc
        fc = forecast_from(reply, window, decl, who, forecaster.source).to_world()
        if modes is None:
            K = fc.n_modes
            modes = np.zeros((S, N, K, T, 2))
            weights = np.full((S, N, K), 1.0 / K)
            spread = np.zeros((S, N, K, T) + ((2, 2) if fc.full_covariance else ()))
        elif fc.n_modes != modes.shape[2] or fc.spread.ndim != spread.ndim - 1:
            raise PredictorError(
                who, f"gave {fc.n_modes} modes at sample {s} after {modes.shape[2]} before (one K per run)"
            )
        slots = window.ped_ids
        modes[s, slots], weights[s, slots], spread[s, slots] = fc.modes, fc.weights, fc.spread
    if modes is None:
        K = decl.modes
        return np.zeros((0, N, K, T, 2)), np.zeros((0, N, K)), np.zeros((0, N, K, T))
    return modes, weights, spread
