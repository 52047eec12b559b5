"""The one planner registry: planner name -> config model and builder.

Names come from four places, all behind the same :class:`PlannerEntry`:

- the built-ins (``predictive``, ``orca``, ``social_force``, ``goal``, ``scripted``);
- ``external``: a separate process speaking the JSON-lines protocol (``core.planners.external``); its config
  names one of the operator-configured commands, never a command line;
- installed plugins: every entry point of the group ``foresight.planners`` (see ``core.sim.planner``);
- in-process planners named ``module:attr`` (or given as Python objects), registered by the process that runs
  them (``register``, used by ``--local`` runs and ``foresight.evaluate``); a server never registers any, so a
  job spec naming one is refused at submission.

The config model of an entry validates a planner's config wherever it enters (YAML, API body, CLI), so a typo
is an error naming the field. ``model`` only concerns the predictive planner. It must be given explicitly, so a
run never falls back to constant velocity unnoticed: ``"cv"``, a ``Forecaster``, or a ``Predictor``.
"""

from __future__ import annotations

import difflib
import importlib
import importlib.metadata
import threading
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any

from pydantic import BaseModel, ConfigDict, ValidationError

from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.sim.planner import PLANNER_API_VERSION, Planner

PLUGIN_GROUP = "foresight.planners"
BUILTIN_NAMES = ("predictive", "orca", "social_force", "goal", "scripted", "sb3")


class NoConfig(BaseModel):
    """The config of a planner that declares none: empty, and any key is an error."""

    model_config = ConfigDict(frozen=True, extra="forbid")


@dataclass(frozen=True)
class PlannerEntry:
    """A planner name: how to validate its config and build a fresh planner per episode."""

    name: str
    config_model: type[BaseModel]
    build: Callable[[BaseModel, Any], Planner]  #: (validated config, model or None) -> planner
    origin: str  #: "builtin", "external", "plugin DIST VERSION" or "module"
    takes_model: bool = False  #: needs a predictor (``model``): the predictive planner only
    description: str = ""
    #: a planner whose config names its own model file (a trained policy): (config, context) -> (id, path)
    model_file: Callable[[BaseModel, Any], tuple[str, Any]] | None = None
    #: loads that file once per process: (path, sha256, config) -> what ``build`` gets as its model
    load_model: Callable[[str, str, BaseModel], Any] | None = None

    def validate(self, config: Any) -> BaseModel:
        """The typed config of a dict (or model); ConfigError naming the first bad field."""
        if isinstance(config, self.config_model):
            return config
        data = config.model_dump() if isinstance(config, BaseModel) else (config or {})
        try:
            return self.config_model.model_validate(data)
        except ValidationError as exc:
            err = exc.errors()[0]
            field = ".".join(str(p) for p in (self.name, *err["loc"]))
            raise ConfigError(f"{err['msg']} ({len(exc.errors())} error(s))", item=field) from None

    def make(self, config: Any = None, model: Any = None) -> Planner:
        return self.build(self.validate(config), model)


# ------------------------------------------------------------------------------ built-ins


def _predictive(cfg: Any, model: Any) -> Planner:
    from foresight.core.planners.predictive.planner import PredictivePlanner

    return PredictivePlanner(cfg, make_forecaster(model))


def _builtins() -> list[PlannerEntry]:
    from foresight.core.planners.external import ExternalPlannerConfig, build_external
    from foresight.core.planners.goal import GoalSeeking, GoalSeekingConfig
    from foresight.core.planners.orca import OrcaConfig, OrcaPlanner
    from foresight.core.planners.predictive.config import PredictivePlannerConfig
    from foresight.core.planners.sb3 import SB3Config, SB3Planner, load_policy, policy_file
    from foresight.core.planners.scripted import Scripted, ScriptedConfig
    from foresight.core.planners.social_force import SocialForceConfig, SocialForcePlanner

    return [
        PlannerEntry(
            "predictive",
            PredictivePlannerConfig,
            _predictive,
            "builtin",
            takes_model=True,
            description="sampling-based planner against a learned (or constant-velocity) crowd forecast",
        ),
        PlannerEntry(
            "orca",
            OrcaConfig,
            lambda c, m: OrcaPlanner(c),
            "builtin",
            description="ORCA velocity obstacles (RVO2) with unicycle tracking",
        ),
        PlannerEntry(
            "social_force",
            SocialForceConfig,
            lambda c, m: SocialForcePlanner(c),
            "builtin",
            description="social-force robot",
        ),
        PlannerEntry(
            "goal",
            GoalSeekingConfig,
            lambda c, m: GoalSeeking(c),
            "builtin",
            description="goal seeking along the route, ignores pedestrians",
        ),
        PlannerEntry(
            "scripted",
            ScriptedConfig,
            lambda c, m: Scripted(c),
            "builtin",
            description="a fixed plan (via points, a wait until a release time, then on): a witness",
        ),
        PlannerEntry(
            "sb3",
            SB3Config,
            lambda c, m: SB3Planner(c, m),
            "builtin",
            description="a Stable-Baselines3 policy trained in foresight/CrowdNav-v0 (the sb3 extra)",
            model_file=policy_file,
            load_model=lambda path, sha, c: load_policy(path, sha, c.algorithm),
        ),
        PlannerEntry(
            "external",
            ExternalPlannerConfig,
            lambda c, m: build_external(c),
            "external",
            description="an operator-configured process speaking the JSON-lines planner protocol",
        ),
    ]


# ------------------------------------------------------------------------------ plugins and Python objects


def entry_of(name: str, obj: Any, origin: str) -> PlannerEntry:
    """The entry of a plugin object: ``obj.config_model`` (optional) and ``obj(config)`` -> planner.

    A planner *instance* (it has ``plan``) is used as is for every episode (in-process runs only).
    """
    api = getattr(obj, "planner_api", PLANNER_API_VERSION)
    if api != PLANNER_API_VERSION:
        raise ConfigError(
            f"planner interface version {api} is not supported (this Foresight: {PLANNER_API_VERSION})",
            item=name,
        )
    doc = (getattr(obj, "__doc__", None) or "").strip().splitlines()
    description = doc[0] if doc else ""
    if hasattr(obj, "plan") and not isinstance(obj, type):
        return PlannerEntry(name, NoConfig, lambda c, m: obj, origin, description=description)
    if not callable(obj):
        raise ConfigError(f"{type(obj).__name__} is neither a planner factory nor a planner", item=name)
    model = getattr(obj, "config_model", None)
    if model is None:
        return PlannerEntry(name, NoConfig, lambda c, m: obj(), origin, description=description)
    if not (isinstance(model, type) and issubclass(model, BaseModel)):
        raise ConfigError("config_model must be a pydantic model class", item=name)
    return PlannerEntry(name, model, lambda c, m: obj(c), origin, description=description)


def _plugins(taken: set[str]) -> list[PlannerEntry]:
    found = []
    for ep in sorted(importlib.metadata.entry_points(group=PLUGIN_GROUP), key=lambda e: e.name):
        dist = f"plugin {ep.dist.name} {ep.dist.version}" if ep.dist else "plugin"
        if ep.name in taken or ":" in ep.name:
            warnings.warn(
                f"planner plugin {ep.name!r} ({dist}) ignored: the name is taken or has a ':'", stacklevel=2
            )
            continue
        try:
            found.append(entry_of(ep.name, ep.load(), dist))
        except Exception as exc:  # noqa: BLE001 - a broken plugin must not take every other planner down
            warnings.warn(f"planner plugin {ep.name!r} ({ep.value}) failed to load: {exc}", stacklevel=2)
    return found


@cache
def installed() -> dict[str, PlannerEntry]:
    """Built-ins and installed plugins by name (loaded once per process)."""
    entries = {e.name: e for e in _builtins()}
    entries.update({e.name: e for e in _plugins(set(entries))})
    return entries


_LOCAL: dict[str, PlannerEntry] = {}  #: in-process planners (``module:attr`` names) this process registered
_LOCK = threading.Lock()


def object_name(obj: Any) -> str:
    """``module:qualname`` of a planner class, factory or instance (its class)."""
    target = obj if isinstance(obj, type) or not hasattr(obj, "plan") else type(obj)
    return f"{target.__module__}:{target.__qualname__}"


def _import(name: str) -> Any:
    module, _, attr = name.partition(":")
    try:
        obj = importlib.import_module(module)
        for part in attr.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as exc:
        raise NotFoundError(f"planner {name!r}: cannot import it ({exc})") from None
    return obj


def register(planner: str | Any) -> str:
    """Make an in-process planner known to this process; returns its name (``module:attr``).

    ``planner`` is a ``module:attr`` string (imported here) or the object itself (a class with an optional
    ``config_model``, a factory, or a planner instance).
    """
    if isinstance(planner, str):
        name, obj = planner, _import(planner)
    else:
        name, obj = object_name(planner), planner
    with _LOCK:
        _LOCAL[name] = entry_of(name, obj, "module")
    return name


def catalogue() -> list[dict[str, Any]]:
    """Every installed planner: name, origin, description, whether it takes a model, its config's JSON schema."""
    return [
        {
            "name": e.name,
            "origin": e.origin,
            "description": e.description,
            "takes_model": e.takes_model,
            "config_schema": e.config_model.model_json_schema(),
        }
        for e in installed().values()
    ]


def names() -> list[str]:
    return [*installed(), *_LOCAL]


def entry(name: str, *, load: bool = False) -> PlannerEntry:
    """The entry of a planner name; NotFoundError listing the installed ones.

    ``module:attr`` names must have been registered in this process, unless ``load`` (a worker process
    rebuilding an already resolved planner imports it).
    """
    found = installed().get(name) or _LOCAL.get(name)
    if found is not None:
        return found
    if ":" in name and load:
        register(name)
        return _LOCAL[name]
    hint = "; module:attr planners run in-process only (--local, foresight.evaluate)" if ":" in name else ""
    close = difflib.get_close_matches(name, list(installed()), n=1)
    hint += f"; did you mean {close[0]!r}?" if close else ""
    raise NotFoundError(f"unknown planner {name!r} (installed: {', '.join(installed())}){hint}")


def make_planner(name: str, config: Any = None, *, model: Any = None) -> Planner:
    """Build a planner by name with an optional config (dict or model; unknown keys are a ConfigError)."""
    return entry(name, load=True).make(config, model)


def make_forecaster(model: Any) -> Any:
    """The predictive planner's forecaster for ``model`` ("cv", "static", a predictor plug-in name or object, a
    Forecaster or a Predictor)."""
    from foresight.core.predict.forecaster import (
        ConstantVelocityForecaster,
        Forecaster,
        LearnedForecaster,
        StaticForecaster,
    )
    from foresight.core.predict.predictor import Predictor
    from foresight.core.predict.timebase import PLANNER_TIMEBASE

    if model is None:
        raise ConfigError(
            "the predictive planner needs a model: 'cv', 'static', a forecaster or a loaded predictor",
            item="model",
        )
    from foresight.core.predict import plugins
    from foresight.core.predict.plugin import PluginForecaster

    if isinstance(model, str):
        if model == "cv":
            return ConstantVelocityForecaster(PLANNER_TIMEBASE)
        if model == "static":
            return StaticForecaster(PLANNER_TIMEBASE)
        if plugins.kind(model):
            return plugins.load(model)
        raise ConfigError(
            f"model {model!r}: resolve ids/paths through the model registry first; "
            "make_planner takes 'cv', 'static', a forecaster or a predictor",
            item="model",
        )
    if isinstance(model, Forecaster):
        return model
    if hasattr(model, "modes") or hasattr(model, "predictor_api"):  # a predictor plug-in object
        return PluginForecaster(model)
    if isinstance(model, Predictor):
        if (
            getattr(model, "frame_convention", "robot") == "focal_pedestrian"
        ):  # an ETH/UCY model, pedestrian by pedestrian
            from foresight.core.predict.focal import FocalForecaster

            return FocalForecaster(model)
        return LearnedForecaster(model)
    raise ConfigError(
        f"model of type {type(model).__name__} is neither a forecaster nor a predictor", item="model"
    )
