"""Planner names -> planner instances: ``make_planner("predictive" | "orca" | "social_force" | "goal", ...)``.

``model`` only concerns the predictive planner. It must be given explicitly, so a run never
falls back to constant velocity unnoticed: ``"cv"`` (constant velocity, recorded as such in every
decision's diagnostics), a ``Forecaster``, or a ``Predictor`` (wrapped in a ``LearnedForecaster``).
Resolving a registry id or checkpoint path into a predictor is the caller's job (model registry).
"""

from __future__ import annotations

from typing import Any

from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.planners.base import Planner

PLANNER_NAMES = ("predictive", "orca", "social_force", "goal")


def make_planner(name: str, config: dict[str, Any] | None = None, *, model: Any = None) -> Planner:
    """Build a planner by name with an optional nested config dict (unknown keys are a ConfigError)."""
    if name == "predictive":
        from foresight.core.planners.predictive.config import PredictivePlannerConfig
        from foresight.core.planners.predictive.planner import PredictivePlanner

        return PredictivePlanner(PredictivePlannerConfig.from_dict(config), make_forecaster(model))
    if name == "orca":
        from foresight.core.planners.orca import OrcaConfig, OrcaPlanner

        return OrcaPlanner(_validate(OrcaConfig, config, name))
    if name == "social_force":
        from foresight.core.planners.social_force import SocialForceConfig, SocialForcePlanner

        return SocialForcePlanner(_validate(SocialForceConfig, config, name))
    if name == "goal":
        from foresight.core.planners.goal import GoalSeeking

        try:
            return GoalSeeking(**(config or {}))
        except TypeError as exc:
            raise ConfigError(str(exc), item="goal") from None
    raise NotFoundError(f"unknown planner {name!r} (known: {', '.join(PLANNER_NAMES)})")


def make_forecaster(model: Any) -> Any:
    """The predictive planner's forecaster for ``model`` ("cv", a Forecaster or a Predictor)."""
    from foresight.core.predict.forecaster import ConstantVelocityForecaster, Forecaster, LearnedForecaster
    from foresight.core.predict.predictor import Predictor
    from foresight.core.predict.timebase import PLANNER_TIMEBASE

    if model is None:
        raise ConfigError("the predictive planner needs a model: 'cv', a forecaster or a loaded predictor",
                          item="model")
    if isinstance(model, str):
        if model == "cv":
            return ConstantVelocityForecaster(PLANNER_TIMEBASE)
        raise ConfigError(f"model {model!r}: resolve ids/paths through the model registry first; "
                          "make_planner takes 'cv', a forecaster or a predictor", item="model")
    if isinstance(model, Forecaster):
        return model
    if isinstance(model, Predictor):
        return LearnedForecaster(model)
    raise ConfigError(f"model of type {type(model).__name__} is neither a forecaster nor a predictor", item="model")


def _validate(cls: Any, config: dict[str, Any] | None, name: str) -> Any:
    from pydantic import ValidationError

    try:
        return cls.model_validate(config or {})
    except ValidationError as exc:
        err = exc.errors()[0]
        raise ConfigError(err["msg"], item=f"{name}." + ".".join(str(p) for p in err["loc"])) from None
