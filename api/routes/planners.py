"""Planners: the names a spec may use here, with their config schemas (``GET /v1/planners``); and the predictor
plug-ins a model field may name (``GET /v1/predictors``)."""

from __future__ import annotations

from fastapi import APIRouter

from foresight.core.planners.external import operator_commands
from foresight.core.planners.registry import catalogue
from foresight.schemas import PlannerPublic, PlannersPublic, PredictorPublic, PredictorsPublic

router = APIRouter(prefix="/planners", tags=["planners"])


@router.get("")
def read_planners() -> PlannersPublic:
    """Built-in planners, installed plugins (entry points of ``foresight.planners``) and ``external`` with the
    operator-configured external planner names (never their command lines)."""
    data = [PlannerPublic(**entry) for entry in catalogue()]
    return PlannersPublic(data=data, count=len(data), external_commands=sorted(operator_commands()))


predictors_router = APIRouter(prefix="/predictors", tags=["planners"])


@predictors_router.get("")
def read_predictors() -> PredictorsPublic:
    """Installed predictor plug-ins (entry points of ``foresight.predictors``) with their declarations, and the
    operator-configured external predictors' names (never their command lines)."""
    from foresight.core.predict import plugins
    from foresight.core.predict.external import operator_commands as predictor_commands

    data = [PredictorPublic(**row) for row in plugins.catalogue()]
    return PredictorsPublic(data=data, count=len(data), external=sorted(predictor_commands()))
