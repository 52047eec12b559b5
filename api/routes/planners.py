"""Planners: the names a spec may use here, with their config schemas (``GET /v1/planners``)."""

from __future__ import annotations

from fastapi import APIRouter

from foresight.api.schemas import PlannerPublic, PlannersPublic
from foresight.core.planners.external import operator_commands
from foresight.core.planners.registry import catalogue

router = APIRouter(prefix="/planners", tags=["planners"])


@router.get("")
def read_planners() -> PlannersPublic:
    """Built-in planners, installed plugins (entry points of ``foresight.planners``) and ``external`` with the
    operator-configured external planner names (never their command lines)."""
    data = [PlannerPublic(**entry) for entry in catalogue()]
    return PlannersPublic(data=data, count=len(data), external_commands=sorted(operator_commands()))
