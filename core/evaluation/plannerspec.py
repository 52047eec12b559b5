"""Which planner an evaluation runs, resolved once: full config (every key), its hash, and the model.

Resolution happens in the parent process before any episode, so that a bad config key or a model
that fails to load stops the run before it starts; workers receive the resolved, picklable form and
rebuild exactly the same planner.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import pickle
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from foresight.core.errors import ConfigError
from foresight.core.planners.base import EpisodeInfo, Planner
from foresight.core.scenarios.model import ResolvedScenario
from foresight.core.stages.context import StageContext

PlannerName = Literal["predictive", "orca", "social_force", "goal"]
CV = "cv"
NO_MODEL = "none"
DEFAULT_MODEL = "default"  #: id resolved through ctx.resolve_model when a predictive run names no model


class PlannerSpec(BaseModel):
    """A planner as a config names it (YAML, API body, CLI)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: PlannerName = "predictive"
    config: dict[str, Any] = Field(default_factory=dict)  #: nested planner config (our keys); defaults fill the rest
    reference_params: dict[str, Any] | None = None  #: reference planner-grid keys (predictive only), mapped by the planner
    variant: str | None = None  #: a label (campaign grid variant name)
    model: str | None = None  #: predictive only: a model id or "cv"; None = the registry's default model


@dataclass(frozen=True)
class ResolvedPlanner:
    """What a worker needs to rebuild the planner; everything here is recorded in the provenance."""

    name: str
    variant: str | None
    config: dict[str, Any]  #: fully resolved (every key, defaults expanded, JSON types)
    config_hash: str  #: sha256 of the canonical JSON of ``config``
    model_id: str  #: model id, "cv", or "none" (planners without a predictor)
    checkpoint_sha256: str  #: checkpoint checksum, or "cv"/"none"
    model_path: str | None = None  #: local checkpoint path (not recorded: differs between machines)

    @property
    def label(self) -> str:
        return self.variant or self.name

    @property
    def learned(self) -> bool:
        return self.model_path is not None


def config_hash(resolved: dict[str, Any]) -> str:
    """sha256 of the canonical JSON (sorted keys, compact) - the same as the predictive config's own hash."""
    return hashlib.sha256(json.dumps(resolved, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _dump_config(cfg: Any) -> dict[str, Any]:
    if isinstance(cfg, BaseModel):
        return cfg.model_dump(mode="json")
    if dataclasses.is_dataclass(cfg):
        return json.loads(json.dumps(dataclasses.asdict(cfg)))
    raise ConfigError(f"cannot resolve a planner config of type {type(cfg).__name__}", item="planner.config")


def _predictive_config(spec: PlannerSpec) -> dict[str, Any]:
    from foresight.core.planners.predictive.config import PredictivePlannerConfig

    cfg = PredictivePlannerConfig.from_dict(spec.config, source="planner.config")
    if spec.reference_params:
        cfg = PredictivePlannerConfig.from_reference_grid(spec.reference_params, base=cfg,
                                                          source=f"planner grid variant {spec.variant or '?'}")
    return cfg.resolved()


_MODELS: dict[tuple[str, str], Any] = {}  #: (path, sha256 of the bytes loaded) -> predictor, per process


def load_model(path: str, sha256: str | None = None) -> Any:
    """Load a checkpoint into a predictor once per process and file content (imports torch only here).

    The bytes loaded must hash to ``sha256`` (None: any; the predictor's ``sha256`` says what was loaded), so
    a file rewritten between resolving and loading, or while worker processes start, fails the run instead
    of being used under another checksum."""
    if sha256 is not None and (path, sha256) in _MODELS:
        return _MODELS[path, sha256]
    predictor = _load_model(path, sha256)
    _MODELS[path, predictor.sha256] = predictor
    return predictor


def _load_model(path: str, sha256: str | None) -> Any:
    from foresight.core.predict.nn.checkpoint import load_predictor

    try:
        return load_predictor(Path(path), expect_sha256=sha256)
    except pickle.UnpicklingError as exc:  # a file torch cannot read at all (not only a wrong payload)
        raise ConfigError(f"not a readable checkpoint ({str(exc).splitlines()[0]})", source=path) from None


def build_planner(rp: ResolvedPlanner) -> Planner:
    """A fresh planner for one episode (the loaded model is shared, it is stateless)."""
    from foresight.core.planners.registry import make_planner

    model = None
    if rp.name == "predictive":
        model = load_model(rp.model_path, rp.checkpoint_sha256) if rp.model_path else CV
    return make_planner(rp.name, rp.config, model=model)


def _model(spec: PlannerSpec, ctx: StageContext) -> tuple[str, str, str | None]:
    """(model id, checkpoint sha256, local path) of a spec; loading it now surfaces a bad model early."""
    if spec.name != "predictive":
        if spec.model not in (None, NO_MODEL):
            raise ConfigError(f"planner {spec.name!r} takes no model", item="model")
        return NO_MODEL, NO_MODEL, None
    if spec.model == CV:
        return CV, CV, None
    ident = spec.model or DEFAULT_MODEL
    path = Path(ctx.resolve_model(ident))
    if not path.is_file():
        raise ConfigError("checkpoint file not found", source=path, item=ident)
    sha = load_model(str(path)).sha256  # a bad model stops the run here, before any episode
    return ident, sha, str(path)  # later loads (worker processes) check their bytes against this checksum


def resolve_planner(spec: PlannerSpec, ctx: StageContext) -> ResolvedPlanner:
    if spec.reference_params and spec.name != "predictive":
        raise ConfigError("reference planner-grid params apply to the predictive planner only",
                          item="planner.reference_params")
    if spec.name == "predictive":
        resolved = _predictive_config(spec)
    else:
        from foresight.core.planners.registry import make_planner

        resolved = _dump_config(make_planner(spec.name, spec.config).config)
    model_id, sha, path = _model(spec, ctx)
    return ResolvedPlanner(name=spec.name, variant=spec.variant, config=resolved, config_hash=config_hash(resolved),
                           model_id=model_id, checkpoint_sha256=sha, model_path=path)


def preflight(rp: ResolvedPlanner, scenarios: list[ResolvedScenario]) -> None:
    """Reset a planner once per distinct time step: an incompatible model fails here, before any episode."""
    seen: set[float] = set()
    for sc in scenarios:
        cfg = sc.scenario.simulation_config
        if cfg.dt in seen:
            continue
        seen.add(cfg.dt)
        build_planner(rp).reset(EpisodeInfo(scenario=sc, seed=0, dt=cfg.dt, robot_radius=sc.scenario.robot_config.radius,
                                            ped_radius=cfg.ped_radius))


def config_diff(a: dict[str, Any], b: dict[str, Any], prefix: str = "") -> dict[str, tuple[Any, Any]]:
    """Key-by-key differences of two resolved configs: dotted key -> (a value, b value); None = key absent."""
    out: dict[str, tuple[Any, Any]] = {}
    for key in list(dict.fromkeys([*a, *b])):
        va, vb = a.get(key), b.get(key)
        path = f"{prefix}{key}"
        if isinstance(va, dict) and isinstance(vb, dict):
            out.update(config_diff(va, vb, path + "."))
        elif va != vb:
            out[path] = (va, vb)
    return out
