"""Predictor plug-in names: wherever a model id is accepted, these name a predictor too.

- installed plug-ins: each entry point of the group ``foresight.predictors`` (its name, e.g. ``cv_noise``);
- ``module:attr``: an importable object, run in-process only (``--local``, ``foresight.evaluate``; a server
  refuses them at submission, as it does ``module:attr`` planners); Python objects handed to the Python API are
  registered under their ``module:qualname``;
- ``external:<name>``: an operator-configured process speaking the JSON-lines predictor protocol
  (``FORESIGHT_EXTERNAL_PREDICTORS``, ``core.predict.external``).

An attribute that is a class or a factory is called without arguments (with ``artifacts=<folder>`` when the model
was registered with files and it takes that keyword); any other object is the predictor itself.
Every name resolves to a :class:`PluginForecaster` whose declaration was checked on load.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import inspect
import threading
from functools import cache
from typing import Any

from foresight.core.errors import NotFoundError
from foresight.core.predict.forecast import PredictorError
from foresight.core.predict.plugin import PREDICTOR_API, PluginForecaster, declaration

PLUGIN_GROUP = "foresight.predictors"
EXTERNAL_PREFIX = "external:"

_LOCAL: dict[str, Any] = {}  #: name -> predictor object registered by this process (Python API)
_LOCK = threading.Lock()


@cache
def installed() -> dict[str, importlib.metadata.EntryPoint]:
    """Entry points of the group ``foresight.predictors`` by name (listed once per process)."""
    return {ep.name: ep for ep in importlib.metadata.entry_points(group=PLUGIN_GROUP)}


def kind(name: Any) -> str | None:
    """ "plugin", "external", "module" for a predictor plug-in name, None for anything else (cv, ids, paths)."""
    if not isinstance(name, str):
        return None
    if name.startswith(EXTERNAL_PREFIX):
        return "external"
    if name in installed():
        return "plugin"
    if name in _LOCAL:
        return "module"
    module, sep, attr = name.partition(":")
    if sep and module and attr and "/" not in name and not name.startswith("file:"):
        return "module"
    return None


def register(obj: Any, name: str | None = None) -> str:
    """Make a Python predictor object known to this process; returns the name it runs under."""
    target = obj if isinstance(obj, type) else type(obj)
    name = name or f"{target.__module__}:{target.__qualname__}"
    declaration(_instance(obj), name)  # refused now, not at the first episode
    with _LOCK:
        _LOCAL[name] = obj
    return name


def _instance(obj: Any, artifacts: str | None = None) -> Any:
    """A class or a factory (callable without ``predict``) is called without arguments, or with ``artifacts`` (a
    registered model's files) when given and it takes that keyword; anything else is used as it is."""
    if not (isinstance(obj, type) or (callable(obj) and not hasattr(obj, "predict"))):
        return obj
    if artifacts is not None:
        try:
            takes = "artifacts" in inspect.signature(obj).parameters
        except (TypeError, ValueError):
            takes = False
        if takes:
            return obj(artifacts=artifacts)
    return obj()


def _load_object(name: str, artifacts: str | None = None) -> Any:
    with _LOCK:
        if name in _LOCAL:
            return _instance(_LOCAL[name], artifacts)
    k = kind(name)
    if k == "plugin":
        ep = installed()[name]
        try:
            obj = ep.load()
        except Exception as exc:  # noqa: BLE001 - the plug-in's own import failure, named
            raise PredictorError(name, f"failed to load ({ep.value}): {exc}") from None
        return _instance(obj, artifacts)
    if k == "module":
        module, _, attr = name.partition(":")
        try:
            obj = importlib.import_module(module)
            for part in attr.split("."):
                obj = getattr(obj, part)
        except (ImportError, AttributeError) as exc:
            raise NotFoundError(f"predictor {name!r}: cannot import it ({exc})") from None
        return _instance(obj, artifacts)
    if k == "external":
        from foresight.core.predict.external import ExternalPredictor

        return ExternalPredictor(name[len(EXTERNAL_PREFIX) :], artifacts=artifacts)
    raise NotFoundError(
        f"predictor {name!r} is not installed (installed plug-ins: {', '.join(installed()) or 'none'}; "
        f"also module:attr, or {EXTERNAL_PREFIX}<name> for an operator-configured process)"
    )


def load(name: str, artifacts: str | None = None) -> PluginForecaster:
    """A fresh forecaster over the predictor plug-in ``name`` (``artifacts``: the folder of a registered model's
    files, handed to it); NotFoundError / PredictorError naming it."""
    obj = _load_object(name, artifacts)
    api = getattr(obj, "predictor_api", PREDICTOR_API)
    if api != PREDICTOR_API:
        raise PredictorError(name, f"speaks predictor interface {api}, this Foresight speaks {PREDICTOR_API}")
    return PluginForecaster(obj, name)


def catalogue() -> list[dict[str, Any]]:
    """Installed predictor plug-ins: name, origin (distribution and version), declaration or load error."""
    out = []
    for name, ep in sorted(installed().items()):
        origin = f"plugin {ep.dist.name} {ep.dist.version}" if ep.dist else "plugin"
        row: dict[str, Any] = {"name": name, "origin": origin}
        try:
            row.update(load(name).declared.to_dict())
        except Exception as exc:  # noqa: BLE001 - one broken plug-in must not hide the others
            row["error"] = str(exc)
        out.append(row)
    return out
