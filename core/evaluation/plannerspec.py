"""Which planner an evaluation runs, resolved once: full config (every key), its hash, and the model.

Resolution happens in the parent process before any episode, so that a bad config key or a model
that fails to load stops the run before it starts; workers receive the resolved, picklable form and
rebuild exactly the same planner.
"""

from __future__ import annotations

import hashlib
import pickle
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal, Union

from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    GetCoreSchemaHandler,
    Tag,
    TypeAdapter,
    ValidationError,
    create_model,
    model_validator,
)

from foresight.core.bounds import BoundedConfig
from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import CV, DEFAULT_MODEL, FORECAST_RULES, NO_MODEL
from foresight.core.scenarios.model import ResolvedScenario
from foresight.core.sim.planner import EpisodeInfo, Planner, config_hash

OTHER = "other"  #: the union member of every other name: in-process planners (``module:attr``) or an error


class PlannerSpecBase(BoundedConfig):
    """A planner as a config names it (YAML, API body, CLI): one typed member per planner name."""

    model_config = ConfigDict(extra="forbid", frozen=True, from_attributes=True)

    name: str = "predictive"
    config: Any = None  #: the planner's config model (our keys); defaults fill the rest
    reference_params: dict[str, Any] | None = (
        None  #: reference planner-grid keys (predictive only), mapped by the planner
    )
    variant: str | None = None  #: a label (campaign grid variant name)
    #: predictive only: a model id, "cv", "static" or a predictor plug-in name; None = the registry's default model
    model: str | None = None


class ModulePlannerSpec(PlannerSpecBase):
    """An in-process planner ``module:attr`` registered by the running process (never on a server)."""

    name: str = Field(max_length=300, json_schema_extra={"pattern": r"^[^:]+:[^:]+$"})  #: schema: module:attr
    config: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _registered(self) -> ModulePlannerSpec:
        from foresight.core.planners.registry import entry

        try:
            entry(self.name).validate(self.config)
        except (NotFoundError, ConfigError) as exc:
            raise ValueError(str(exc)) from None
        return self


def _tagger(typed: set[str]) -> Any:
    def tag(value: Any) -> str:
        name = (
            value.get("name", "predictive")
            if isinstance(value, dict)
            else getattr(value, "name", "predictive")
        )
        return name if isinstance(name, str) and name in typed else OTHER

    return tag


def _member(name: str, config_model: type[BaseModel]) -> type[PlannerSpecBase]:
    title = "".join(p.title() for p in re.split(r"[^A-Za-z0-9]+", name))
    return create_model(
        f"{title}PlannerSpec",
        __base__=PlannerSpecBase,
        __doc__=f"Planner {name!r} and its config.",
        name=(Literal[name], name if name == "predictive" else ...),  # only it is the default
        config=(config_model, Field(default_factory=config_model)),
    )


def _planner_spec_type() -> Any:
    """The typed union keyed by planner name: built-ins', external's and every installed plugin's config model."""
    from foresight.core.planners.registry import installed

    entries = installed()
    members = [Annotated[_member(n, e.config_model), Tag(n)] for n, e in entries.items()]
    members.append(Annotated[ModulePlannerSpec, Tag(OTHER)])
    return Annotated[Union[tuple(members)], Discriminator(_tagger(set(entries)))]  # noqa: UP007 (runtime tuple)


_UNION = _planner_spec_type()
_ADAPTER: TypeAdapter[Any] = TypeAdapter(_UNION)


class PlannerSpec:
    """The planner field of a config (the typed union keyed by name) and its constructor:
    ``PlannerSpec(name="goal", config={"speed": 0.8})`` returns the typed member (see :func:`planner_spec`)."""

    def __new__(cls, spec: Any = None, /, **fields: Any) -> PlannerSpecBase:  # type: ignore[misc]
        return planner_spec(spec, **fields)

    @classmethod
    def __get_pydantic_core_schema__(cls, source: Any, handler: GetCoreSchemaHandler) -> Any:
        return handler.generate_schema(_UNION)


def planner_spec(spec: Any = None, /, **fields: Any) -> PlannerSpecBase:
    """The typed spec of a dict, a spec or keyword fields: ``planner_spec(name="goal", config={"speed": 0.8})``."""
    try:
        return _ADAPTER.validate_python(fields if spec is None else spec)
    except ValidationError as exc:
        err = exc.errors()[0]
        raise ConfigError(err["msg"], item=".".join(str(p) for p in ("planner", *err["loc"]))) from None


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
    origin: str = "builtin"  #: where the planner's code came from: "builtin", "external", "plugin DIST VERSION", "module"

    @property
    def label(self) -> str:
        return self.variant or self.name

    @property
    def learned(self) -> bool:
        return self.model_path is not None


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


_MODELS: dict[
    tuple[str, str, str | None], Any
] = {}  #: (path, sha256 of the bytes loaded, id) -> predictor, per process


def load_model(path: str, sha256: str | None = None, name: str | None = None) -> Any:
    """Load a checkpoint into a predictor once per process and file content (imports torch only here).

    The bytes loaded must hash to ``sha256`` (None: any; the predictor's ``sha256`` says what was loaded), so
    a file rewritten between resolving and loading, or while worker processes start, fails the run instead
    of being used under another checksum. ``name``: the model id its errors name (default: the file's stem)."""
    if sha256 is not None and (path, sha256, name) in _MODELS:
        return _MODELS[path, sha256, name]
    predictor = _load_model(path, sha256, name)
    _MODELS[path, predictor.sha256, name] = predictor
    return predictor


def _load_model(path: str, sha256: str | None, name: str | None) -> Any:
    from foresight.core.predict.nn.checkpoint import load_predictor

    try:
        return load_predictor(Path(path), expect_sha256=sha256, name=name)
    except pickle.UnpicklingError as exc:  # a file torch cannot read at all (not only a wrong payload)
        raise ConfigError(f"not a readable checkpoint ({str(exc).splitlines()[0]})", source=path) from None


def build_planner(rp: ResolvedPlanner) -> Planner:
    """A fresh planner for one episode (the loaded model is shared, it is stateless)."""
    from foresight.core.planners.registry import entry, make_planner
    from foresight.core.predict import plugins, registered

    model = None
    found = entry(rp.name, load=True)  # a worker process imports a module:attr planner by its name
    if found.load_model is not None:  # a policy file its config names
        model = found.load_model(rp.model_path, rp.checkpoint_sha256, found.validate(rp.config))
    elif rp.model_id in FORECAST_RULES and not rp.model_path:
        model = rp.model_id  # constant velocity or static, built by rule
    elif plugins.kind(rp.model_id):
        model = rp.model_id  # a predictor plug-in: the planner loads a fresh one (its own state per episode)
    elif registered.is_registered(rp.model_path):  # a registered plug-in or external model: its predictor
        model = plugins.load(registered.predictor_name(rp.model_path), registered.files_dir(rp.model_path))
    elif rp.model_id != NO_MODEL:
        model = load_model(rp.model_path, rp.checkpoint_sha256, rp.model_id) if rp.model_path else CV
    return make_planner(rp.name, rp.config, model=model)


def _model(spec: PlannerSpecBase, found: Any, cfg: Any, ctx: StageContext) -> tuple[str, str, str | None]:
    """(model id, checkpoint sha256, local path) of a spec; loading it now surfaces a bad model early."""
    takes_model = found.takes_model
    if found.model_file is not None:  # the config names the file (a trained policy), not ``model``
        if spec.model not in (None, NO_MODEL):
            raise ConfigError(
                f"planner {spec.name!r} takes no model: its config names its file", item="model"
            )
        ident, path = found.model_file(cfg, ctx)
        sha = sha256_file(Path(path))
        found.load_model(str(path), sha, cfg)  # a bad file stops the run here, before any episode
        return ident, sha, str(path)
    if not takes_model:
        if spec.model not in (None, NO_MODEL):
            raise ConfigError(f"planner {spec.name!r} takes no model", item="model")
        return NO_MODEL, NO_MODEL, None
    if spec.model in FORECAST_RULES:  # built by rule, no file: the id is its own checksum
        return spec.model, spec.model, None
    from foresight.core.predict import plugins

    kind = plugins.kind(spec.model)
    if (
        kind
    ):  # a predictor plug-in: loaded now, so a missing or malformed one stops the run before any episode
        declared = plugins.load(spec.model).declared
        return spec.model, f"{kind}:{declared.name}", None
    ident = spec.model or DEFAULT_MODEL
    path = Path(ctx.resolve_model(ident))
    from foresight.core.predict import registered

    if registered.is_registered(
        path
    ):  # a registered plug-in or external model (its files checked): loaded now
        name = registered.predictor_name(path)
        declared = plugins.load(name, registered.files_dir(path)).declared
        return ident, f"{plugins.kind(name)}:{declared.name}", str(path)
    if not path.is_file():
        raise ConfigError("checkpoint file not found", source=path, item=ident)
    sha = load_model(str(path), name=ident).sha256  # a bad model stops the run here, before any episode
    return ident, sha, str(path)  # later loads (worker processes) check their bytes against this checksum


def planner_config(spec: PlannerSpecBase | dict[str, Any]) -> BaseModel:
    """A spec's full planner config (defaults expanded, reference grid params mapped), checked without a model:
    ConfigError naming the key for an unknown one, a value out of range, NaN or Infinity. Campaigns check their
    inline variants with it at submission (an unknown key failed only in the worker)."""
    from foresight.core.limits import hostile_values
    from foresight.core.planners.registry import entry

    spec = planner_spec(spec)
    source = f"planner grid variant {spec.variant}" if spec.variant else None
    cfg = entry(spec.name).validate(spec.config)
    if spec.reference_params:
        if spec.name != "predictive":
            raise ConfigError(
                "reference planner-grid params apply to the predictive planner only",
                item="planner.reference_params",
            )
        cfg = type(cfg).from_reference_grid(
            spec.reference_params, base=cfg, source=source or "planner grid variant ?"
        )
    for loc, why in hostile_values(cfg.model_dump()):
        raise ConfigError(why, source=source, item=".".join(str(p) for p in ("planner", "config", *loc)))
    return cfg


def resolve_planner(spec: PlannerSpecBase | dict[str, Any], ctx: StageContext) -> ResolvedPlanner:
    """Every key of the planner's config (defaults expanded), its hash and its model, checked before any episode."""
    from foresight.core.planners.registry import entry

    spec = planner_spec(spec)
    found = entry(spec.name)
    cfg = planner_config(spec)
    resolved = cfg.model_dump(mode="json")
    model_id, sha, path = _model(spec, found, cfg, ctx)
    return ResolvedPlanner(
        name=spec.name,
        variant=spec.variant,
        config=resolved,
        config_hash=config_hash(resolved),
        model_id=model_id,
        checkpoint_sha256=sha,
        model_path=path,
        origin=found.origin,
    )


#: the command types a planner may declare, and what each command is
COMMANDS = {"unicycle": "(v [m/s], omega [rad/s])", "velocity": "world-frame (vx, vy) [m/s]"}


def preflight(rp: ResolvedPlanner, scenarios: list[ResolvedScenario]) -> None:
    """Reset a planner once per distinct time step: an incompatible model fails here, before any episode; so does a
    planner whose declared command type (``command_type``) the scenario's robot does not take."""
    from foresight.core.planners.external import ExternalPlannerError

    declared = rp.config.get("command_type")
    for sc in scenarios if declared is not None else ():
        kind = sc.scenario.robot_config.kinematics
        wanted = "velocity" if kind == "holonomic" else "unicycle"
        if declared != wanted:
            raise ConfigError(
                f"planner {rp.label!r} sends {declared} commands but the scenario's robot_config.kinematics is "
                f"{kind!r}, which takes {wanted} commands ({COMMANDS[wanted]})",
                source=sc.name,
                item="planner.config.command_type",
            )
    seen: set[float] = set()
    for sc in scenarios:
        cfg = sc.scenario.simulation_config
        if cfg.dt in seen:
            continue
        seen.add(cfg.dt)
        info = EpisodeInfo(
            scenario=sc,
            seed=0,
            dt=cfg.dt,
            robot_radius=sc.scenario.robot_config.radius,
            ped_radius=cfg.ped_radius,
        )
        try:
            build_planner(rp).reset(info)
        except ExternalPlannerError as exc:  # a command that cannot start: one line, before any episode
            raise ConfigError(str(exc), item="planner.config.command") from None
        except ConfigError as exc:
            if exc.source is not None:
                raise
            raise ConfigError(
                f"planner {rp.label!r} cannot run this scenario (dt {cfg.dt:g} s): {exc.detail}",
                source=sc.name,
                item=exc.item,
            ) from None


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
