"""The pipeline config: the seed runbook's stages, each section a stage config defined once in core.

A section is its stage's config class with the fields the pipeline wires in (datasets, model ids, the
seed manifests, the bundle and matrix) made optional; :func:`stage_config` builds the real stage config
from a section and the outputs of the stages before it. The two seed manifests are named once at the
top: ``training_seeds`` feeds hard-case collection and proxy selection, ``evaluation_seeds`` feeds
diagnostics and the campaign's hard suite (and so the gates); they must not share a (scenario, seed).
``selection`` moves closed-loop model selection (the training proxy) to a suite where constant velocity and
a good model differ, the stress suite, on that suite's TRAINING seeds (checked at run time to hold none of
its matrix's own, evaluation, seeds: ``core.training.proxy``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from foresight.core.bounds import BoundedConfig
from foresight.core.errors import ConfigError
from foresight.core.evaluation.config import CampaignConfig, DiagnosticsConfig, EvaluationConfig
from foresight.core.evaluation.conformance import ConformanceConfig
from foresight.core.evaluation.regression import FloorsConfig, RegressionGateConfig
from foresight.core.runtime.refs import BUILTIN_BUNDLE, RESERVED_MODEL_IDS, BundlePath, Ident
from foresight.core.training.collect import CollectConfig, MixConfig
from foresight.core.training.config import TrainConfig
from foresight.core.training.proxy import ProxySpec
from foresight.core.yamlio import load_yaml

#: placeholder for the model this pipeline trains and registers (planner.model, campaign checkpoints)
CANDIDATE = "candidate"
GateName = Literal["training", "evaluation", "closed_loop", "regression", "floors", "conformance"]
#: the incumbent section's ``model`` that picks the model the candidate would replace (``incumbent_rule``)
AUTO = "auto"
#: placeholder for the incumbent in campaign checkpoints
INCUMBENT = "incumbent"


class CollectSection(CollectConfig):
    """Base collection: every scenario x ``seeds_per_scenario`` seeds from ``base_seed`` (keep it outside
    the evaluation seed range: the matrix's own seeds are below 10000)."""

    base_seed: int = Field(default=50_000, ge=0)
    output: str = "base.npz"

    @model_validator(mode="after")
    def _no_manifest(self) -> CollectSection:
        if self.hard_seeds is not None:
            raise ValueError(
                "base collection takes no seed manifest; the hard-case stage uses training_seeds"
            )
        return self


class HardcaseSection(CollectConfig):
    """Hard-case collection on the TRAINING manifest (``training_seeds``; set here only to the same file)."""

    output: str = "hardcase.npz"


class MixSection(MixConfig):
    base: str = ""  #: wired: the base dataset
    hardcase: str = ""  #: wired: the hard-case dataset


class TrainSection(TrainConfig):
    dataset: str = ""  #: wired: the mixed dataset (or the base one without a hard-case stage)


class RegisterSection(BaseModel):
    model_config = ConfigDict(extra="forbid")
    model_id: Ident | None = None  #: default: ``<pipeline name>-<run id>``
    tags: list[str] = Field(default_factory=list, max_length=20)

    @field_validator("model_id")
    @classmethod
    def _not_reserved(cls, value: str | None) -> str | None:
        """Refused at submission, not after training: the registry refuses ids that name a rule."""
        if value is not None and value.lower() in RESERVED_MODEL_IDS:
            raise ValueError(f"model id {value!r} is reserved ({', '.join(sorted(RESERVED_MODEL_IDS))})")
        return value


class EvaluateSection(EvaluationConfig):
    """The candidate on the global suite (``planner.model`` None or "candidate" = the registered model)."""


class DiagnoseSection(DiagnosticsConfig):
    seed_manifest: BundlePath | None = None  #: wired: ``evaluation_seeds``


class CampaignSection(CampaignConfig):
    seed_manifest: BundlePath | None = None  #: wired: ``evaluation_seeds``
    checkpoints: list[str] = Field(default_factory=lambda: [CANDIDATE], min_length=1, max_length=50)


class ConformanceSection(ConformanceConfig):
    """The conformance check of the planner the evaluate stage runs (``planner`` wired: evaluate's, with the
    candidate model); on a scenario of the pipeline's matrix."""


class SelectionSection(BaseModel):
    """The closed-loop model-selection suite of the training proxy (default: ``matrix`` x ``training_seeds``)."""

    model_config = ConfigDict(extra="forbid")
    matrix: BundlePath  #: e.g. scenarios/stress.yaml
    seeds: BundlePath  #: that matrix's TRAINING seed manifest (e.g. seeds/stress_train_quick.yaml)


class IncumbentSection(BaseModel):
    """The model the candidate would replace, run on the candidate's episodes (evaluate, diagnose).

    ``model``: ``auto`` = the default model when the pipeline promotes to default, else the newest promoted model
    of the same lineage (registered by a pipeline of this name), else the default; or a model id; or None (no
    incumbent: a required regression gate then fails). ``planner_config``: the planner config the incumbent runs
    with (None: the candidate's, so only the model differs)."""

    model_config = ConfigDict(extra="forbid")
    model: Ident | None = AUTO
    planner_config: dict[str, Any] | None = None


class GatesSection(BaseModel):
    """Which gates must have run and passed before the candidate is promoted (a required gate whose stage did not
    run fails). A gate that ran and failed blocks promotion whether it is listed or not. ``relaxed``: the gates are
    lenient on purpose (smoke sizes): the model is registered with status ``relaxed``, which can never be
    promoted or become the default, whatever the gates say."""

    model_config = ConfigDict(extra="forbid")
    require: list[GateName] = Field(
        default_factory=lambda: [
            "training",
            "evaluation",
            "closed_loop",
            "regression",
            "floors",
            "conformance",
        ]
    )
    regression: RegressionGateConfig = RegressionGateConfig()  #: candidate vs incumbent, same episodes
    floors: FloorsConfig = FloorsConfig()  #: candidate vs constant velocity, same episodes
    relaxed: bool = False


class PromoteSection(BaseModel):
    model_config = ConfigDict(extra="forbid")
    to: Literal["promoted", "default"] = "promoted"


class PipelineConfig(BoundedConfig):
    """collect -> hard-case collect -> mix -> train (proxy on the training seeds) -> register (candidate) ->
    evaluate -> diagnose -> campaign -> gates -> promote."""

    model_config = ConfigDict(extra="forbid")

    name: Ident = "pipeline"
    description: str = ""
    bundle: Ident = BUILTIN_BUNDLE
    matrix: BundlePath = "scenarios/classic_interactions.yaml"
    training_seeds: BundlePath  #: TRAINING hard-seed manifest: hard-case collection + proxy selection
    evaluation_seeds: BundlePath  #: EVALUATION hard-seed manifest: diagnostics + campaign hard suite
    #: processes each episode stage may use; None: the worker's own (FORESIGHT_STAGE_WORKERS; --local: 1)
    workers: int | None = Field(default=None, ge=1, le=64)
    collect: CollectSection = CollectSection()
    hardcase: HardcaseSection | None = HardcaseSection()  #: None: no hard-case collection and no mix
    mix: MixSection = MixSection()
    train: TrainSection = TrainSection()
    selection: SelectionSection | None = None  #: proxy selection suite; None: matrix x training_seeds
    registration: RegisterSection = RegisterSection()  #: the register stage (model id, tags)
    evaluate: EvaluateSection = EvaluateSection()
    diagnose: DiagnoseSection | None = DiagnoseSection()  #: None: skip diagnostics
    campaign: CampaignSection
    conformance: ConformanceSection | None = ConformanceSection()  #: None: no conformance check
    incumbent: IncumbentSection = IncumbentSection()
    gates: GatesSection = GatesSection()
    promote: PromoteSection = PromoteSection()

    @model_validator(mode="after")
    def _wiring(self) -> PipelineConfig:
        if self.training_seeds == self.evaluation_seeds:
            raise ValueError("training_seeds and evaluation_seeds must be different manifests")
        for name in ("collect", "hardcase", "evaluate", "diagnose", "campaign", "conformance"):
            section = getattr(self, name)
            if section is None:
                continue
            for key in ("bundle", "matrix"):
                if key in section.model_fields_set and getattr(section, key) != getattr(self, key):
                    raise ValueError(
                        f"{name}.{key} differs from the pipeline's {key}; set it once at the top"
                    )
        for name, key in (
            ("hardcase", "hard_seeds"),
            ("diagnose", "seed_manifest"),
            ("campaign", "seed_manifest"),
        ):
            section = getattr(self, name)
            want = self.training_seeds if name == "hardcase" else self.evaluation_seeds
            value = getattr(section, key, None) if section is not None else None
            if value is not None and value != want:
                raise ValueError(
                    f"{name}.{key} must be the pipeline's "
                    f"{'training_seeds' if name == 'hardcase' else 'evaluation_seeds'} (or unset)"
                )
        if self.selection is not None and self.selection.seeds == self.evaluation_seeds:
            raise ValueError("selection.seeds must be a TRAINING manifest, not the evaluation_seeds")
        proxy, want = self.train.proxy, self.selection.seeds if self.selection else self.training_seeds
        if proxy is not None and proxy.seed_manifest not in (None, want):
            raise ValueError(
                f"train.proxy.seed_manifest must be {want} (selection.seeds, else training_seeds) or unset"
            )
        return self


def _build(model: type[BaseModel], data: dict[str, Any], stage: str) -> Any:
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        raise ConfigError(
            err["msg"], source="pipeline", item=".".join([stage, *map(str, err["loc"])])
        ) from None


def _model(value: str | None, candidate: str, incumbent: str | None = None) -> str:
    if value == INCUMBENT:
        if incumbent is None:
            raise ConfigError(
                "the pipeline has no incumbent model", source="pipeline", item="incumbent.model"
            )
        return incumbent
    return candidate if value in (None, CANDIDATE) else value


def stage_config(config: PipelineConfig, stage: str, inputs: dict[str, str]) -> BaseModel:
    """The stage config of ``stage`` with its wired inputs.

    ``inputs``: ``base``/``hardcase``/``mixed`` dataset ids, ``model`` (the registered candidate's id) and
    ``incumbent`` (the incumbent's id, when there is one).
    """
    where = {"bundle": config.bundle, "matrix": config.matrix}
    if stage == "collect":
        return _build(CollectConfig, {**config.collect.model_dump(), **where}, stage)
    if stage == "hardcase":
        assert config.hardcase is not None
        return _build(
            CollectConfig,
            {**config.hardcase.model_dump(), **where, "hard_seeds": config.training_seeds},
            stage,
        )
    if stage == "mix":
        return _build(
            MixConfig,
            {**config.mix.model_dump(), "base": inputs["base"], "hardcase": inputs["hardcase"]},
            stage,
        )
    if stage == "train":
        data = config.train.model_dump()
        data["dataset"] = inputs.get("mixed") or inputs["base"]
        if config.train.proxy_every > 0:
            proxy = (config.train.proxy or ProxySpec()).model_dump()
            sel = config.selection
            proxy.update(
                where,
                matrix=sel.matrix if sel else config.matrix,
                scenarios=None,
                seeds_per_scenario=None,
                seed_manifest=sel.seeds if sel else config.training_seeds,
            )
            data["proxy"] = proxy
        return _build(TrainConfig, data, stage)
    if stage == "evaluate":
        data = config.evaluate.model_dump()
        data.update(where)
        data["planner"]["model"] = (
            _model(data["planner"].get("model"), inputs["model"])
            if data["planner"]["name"] == "predictive"
            else data["planner"].get("model")
        )
        return _build(EvaluationConfig, data, stage)
    if stage == "diagnose":
        assert config.diagnose is not None
        data = config.diagnose.model_dump()
        data.update(where, seed_manifest=config.evaluation_seeds)
        if data["planner"]["name"] == "predictive":
            data["planner"]["model"] = _model(data["planner"].get("model"), inputs["model"])
        return _build(DiagnosticsConfig, data, stage)
    if stage == "conformance":
        assert config.conformance is not None
        evaluate = stage_config(config, "evaluate", inputs).model_dump(mode="json")
        data = {**config.conformance.model_dump(mode="json"), **where, "planner": evaluate["planner"]}
        return _build(ConformanceConfig, data, stage)
    if stage == "campaign":
        data = config.campaign.model_dump()
        data.update(where, seed_manifest=config.evaluation_seeds)
        data["checkpoints"] = list(
            dict.fromkeys(_model(c, inputs["model"], inputs.get("incumbent")) for c in data["checkpoints"])
        )
        return _build(CampaignConfig, data, stage)
    raise ConfigError(f"no stage config for {stage!r}", source="pipeline", item=stage)


def load_pipeline_config(path: str | Path) -> PipelineConfig:
    """Read a pipeline YAML; errors name the file and the field."""
    path = Path(path)
    try:
        data = load_yaml(path.read_text(), source=path)
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"cannot read YAML ({exc})", source=path) from None
    try:
        return PipelineConfig.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        raise ConfigError(
            err["msg"], source=path, item=".".join(str(p) for p in err["loc"]) or None
        ) from None
