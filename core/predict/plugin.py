"""Predictor plug-ins: an observation window in, a forecast out (docs/predictor_protocol.md).

A plug-in is any object with ``name``, ``timebase`` (a TimeBase or {dt, history, horizon}), ``frame`` ("world" or
"pedestrian"), ``modes`` (K, the modes it returns per pedestrian) and ``predict(window) -> Forecast | dict``. The
dict form is the external protocol's forecast message (``modes``, ``weights``, ``sigma`` or ``covariance``,
optionally ``anchors``), so one parser serves both. :class:`PluginForecaster` keeps the live history on the
plug-in's time base, asks it once per decision and holds the answer to the contract (``check_forecast``): every
break is a PredictorError naming the plug-in.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from foresight.core.predict.forecast import FRAMES, Forecast, PredictorError, check_forecast
from foresight.core.predict.history import LiveHistory
from foresight.core.predict.timebase import TimeBase
from foresight.core.sim.observation import Observation

PREDICTOR_API = 1


@dataclass(frozen=True)
class ObservationWindow:
    """What a predictor sees at one instant, world frame, on its own time base."""

    time: float  #: [s] of the current step
    dt: float  #: [s] between history steps (the predictor's declared dt)
    ped_ids: np.ndarray  #: (N,) int64 the pedestrians present now, to be forecast in this order
    history: np.ndarray  #: (N, H, 2) positions [m], oldest first; the current one is [:, -1]
    valid: np.ndarray  #: (N, H) bool: observed (the current step always is; unobserved positions are 0)
    robot_pose: np.ndarray  #: (3,) x, y, heading [m, m, rad]
    robot_velocity: np.ndarray  #: (2,) v [m/s], omega [rad/s]
    waypoint: np.ndarray | None = None  #: (2,) the robot's current waypoint, None without a robot

    def anchors(self) -> np.ndarray:
        """(N, 3) each pedestrian's own frame: last observed position and the heading of its last observed
        displacement (backward difference; 0 = world x when it stood still or has one observation)."""
        cur = self.history[:, -1]
        heading = np.zeros(len(cur))
        if self.history.shape[1] > 1:
            ok = self.valid[:, -1] & self.valid[:, -2]
            d = cur - self.history[:, -2]
            moved = ok & (np.hypot(d[:, 0], d[:, 1]) > 1e-9)
            heading[moved] = np.arctan2(d[moved, 1], d[moved, 0])
        return np.column_stack([cur, heading])

    def to_message(self) -> dict[str, Any]:
        """The external protocol's ``observe`` message (unobserved steps are null)."""
        hist = np.where(self.valid[..., None], np.round(self.history, 6), np.nan).tolist()  # um: short lines
        return self._message([[None if p[0] != p[0] else p for p in track] for track in hist])

    def to_line(self) -> bytes:
        """``to_message`` as one JSON line. With every step observed (the usual case) the history's numbers are
        written by one %-format of a cached template (%.6f, 1 um, as ``to_message`` rounds them): each float's
        shortest repr in json.dumps was most of the cost of sending a window."""
        if not self.history.size or not self.valid.all():  # unobserved steps are null: the general route
            return (json.dumps(self.to_message(), separators=(",", ":")) + "\n").encode()
        history = _history_format(*self.valid.shape) % tuple(
            np.asarray(self.history, dtype=float).ravel().tolist()
        )
        head, tail = json.dumps(self._message(None), separators=(",", ":")).split('"history":null', 1)
        return (head + '"history":' + history + tail + "\n").encode()

    def _message(self, history: Any) -> dict[str, Any]:
        msg: dict[str, Any] = {
            "type": "observe",
            "time": float(self.time),
            "dt": float(self.dt),
            "pedestrians": {"ids": np.asarray(self.ped_ids).tolist(), "history": history},
            "robot": {
                "pose": np.asarray(self.robot_pose, float).tolist(),
                "velocity": np.asarray(self.robot_velocity, float).tolist(),
            },
        }
        if self.waypoint is not None:
            msg["robot"]["waypoint"] = np.asarray(self.waypoint, float).tolist()
        return msg


@functools.lru_cache(maxsize=64)
def _history_format(n: int, h: int) -> str:
    """The JSON template of an (n, h, 2) history, every step observed."""
    track = "[" + ",".join(["[%.6f,%.6f]"] * h) + "]"
    return "[" + ",".join([track] * n) + "]"


@runtime_checkable
class PredictorPlugin(Protocol):
    name: str
    timebase: Any  #: TimeBase or {dt, history, horizon}
    frame: str
    modes: int

    def predict(self, window: ObservationWindow) -> Any: ...


@dataclass(frozen=True)
class Declaration:
    """What a predictor declares about its forecasts, checked once when it is loaded."""

    name: str
    timebase: TimeBase
    frame: str
    modes: int

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "timebase": self.timebase.to_dict(),
            "frame": self.frame,
            "modes": self.modes,
        }


def declaration(obj: Any, who: str) -> Declaration:
    """The checked declaration of a plug-in object; PredictorError naming ``who`` when one is missing or wrong."""
    missing = [a for a in ("timebase", "predict") if not hasattr(obj, a)]
    if missing:
        raise PredictorError(
            who, f"is not a predictor plug-in: it lacks {', '.join(missing)} (see the protocol)"
        )
    tb = obj.timebase
    try:
        tb = tb if isinstance(tb, TimeBase) else TimeBase.from_dict(tb, source=who)
    except Exception as exc:  # noqa: BLE001 - any malformed declaration is the plug-in's error
        raise PredictorError(who, f"declares a bad time base: {exc}") from None
    frame = getattr(obj, "frame", "world")
    if frame not in FRAMES:
        raise PredictorError(who, f"declares frame {frame!r}, expected one of {', '.join(FRAMES)}")
    modes = getattr(obj, "modes", 1)
    if isinstance(modes, bool) or not isinstance(modes, int | np.integer) or modes < 1:
        raise PredictorError(who, f"declares modes={modes!r}, expected an integer >= 1")
    return Declaration(str(getattr(obj, "name", who)), tb, frame, int(modes))


def _array(data: dict[str, Any], key: str, who: str) -> np.ndarray:
    try:
        return np.asarray(data[key], dtype=float)
    except KeyError:
        raise PredictorError(who, f"forecast message lacks {key!r}") from None
    except (TypeError, ValueError):
        raise PredictorError(who, f"forecast {key!r} is not a regular numeric array") from None


def forecast_from(
    reply: Any, window: ObservationWindow, decl: Declaration, who: str, source: str
) -> Forecast:
    """A plug-in's answer (a Forecast or the forecast message dict) as a checked Forecast on its declared time base.

    In the message any array may also come flat (1-D, C order: ``modes`` N K T 2 numbers, ``weights`` N K,
    ``sigma`` N K T, ``covariance`` N K T 4), and ``sigma`` as one (T,) spread for every pedestrian and mode: nested
    JSON lists cost a list object per innermost pair to build and to parse."""
    if isinstance(reply, Forecast):
        fc = reply
    elif isinstance(reply, dict):
        n, T = len(window.ped_ids), decl.timebase.horizon
        modes = _array(reply, "modes", who)
        if modes.ndim == 1 and n and modes.size and modes.size % (n * T * 2) == 0:  # flat, in C order
            modes = modes.reshape(n, -1, T, 2)
        k = modes.shape[1] if modes.ndim >= 2 else 0
        weights = _array(reply, "weights", who) if "weights" in reply else np.full((n, k), 1.0 / max(k, 1))
        if weights.ndim == 1 and n and weights.size == n * k:
            weights = weights.reshape(n, k)
        if "covariance" in reply:
            spread = _array(reply, "covariance", who)
            if spread.ndim == 1 and n and spread.size == n * k * T * 4:
                spread = spread.reshape(n, k, T, 2, 2)
        elif "sigma" in reply:
            spread = _array(reply, "sigma", who)
            if spread.ndim == 1 and n and spread.size == n * k * T:
                spread = spread.reshape(n, k, T)
            elif spread.shape == (T,):  # one spread for every pedestrian and mode
                spread = np.repeat(spread[None, None], n * k, axis=0).reshape(n, k, T)
        else:
            raise PredictorError(
                who, "forecast message lacks 'sigma' (N, K, T) or 'covariance' (N, K, T, 2, 2)"
            )
        if n == 0:  # an empty JSON list has no inner shape
            modes, weights = modes.reshape(0, k or 1, T, 2), weights.reshape(0, k or 1)
            spread = spread.reshape((0, k or 1, T) + ((2, 2) if "covariance" in reply else ()))
        frame = reply.get("frame", decl.frame)
        anchors = reply.get("anchors")
        fc = Forecast(
            ped_ids=np.asarray(window.ped_ids, dtype=np.int64),
            modes=modes,
            weights=weights,
            spread=spread,
            times=decl.timebase.times,
            source=source,
            timebase=decl.timebase,
            frame=frame if isinstance(frame, str) else repr(frame),
            anchors=None if anchors is None else np.asarray(anchors, dtype=float),
        )
    else:
        raise PredictorError(who, f"returned {type(reply).__name__}, expected a Forecast or a forecast dict")
    if fc.frame == "pedestrian" and fc.anchors is None:
        from dataclasses import replace

        fc = replace(fc, anchors=window.anchors())
    return check_forecast(fc, who, ped_ids=window.ped_ids, min_modes=decl.modes, timebase=decl.timebase)


class PluginForecaster:
    """The Forecaster protocol over a predictor plug-in (in-process object or external process)."""

    def __init__(self, predictor: Any, who: str | None = None):
        self.predictor = predictor
        self.who = who or str(getattr(predictor, "name", type(predictor).__name__))
        self.declared = declaration(predictor, self.who)
        self.timebase = self.declared.timebase
        self.source = f"plugin:{self.who}"
        self.history = LiveHistory(self.timebase)
        self._obs: Observation | None = None

    def reset(self) -> None:
        self.history.reset()
        if hasattr(self.predictor, "reset"):
            self.predictor.reset()

    def observe(self, obs: Observation) -> None:
        self.history.observe(obs)
        self._obs = obs

    def update(self, obs: Observation) -> Forecast:
        self.observe(obs)
        return self.forecast()

    def window(self) -> ObservationWindow:
        w, obs = self.history.window(), self._obs
        return ObservationWindow(
            time=float(obs.time),
            dt=self.timebase.dt,
            ped_ids=w.ped_ids,
            history=w.ped_hist,
            valid=w.hist_valid,
            robot_pose=w.ego_pose,
            robot_velocity=w.ego_motion,
            waypoint=w.goal,
        )

    def forecast(self) -> Forecast:
        window = self.window()
        try:
            reply = self.predictor.predict(window)
        except PredictorError:
            raise
        except Exception as exc:  # noqa: BLE001 - the plug-in's own failure, named
            raise PredictorError(self.who, f"raised {type(exc).__name__}: {exc}") from exc
        return forecast_from(reply, window, self.declared, self.who, self.source)
