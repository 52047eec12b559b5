"""Pydantic configs and results of the prediction stages (defined once: YAML, API bodies, CLI)."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, ValidationInfo, field_validator

from foresight.core.bounds import BoundedConfig
from foresight.core.errors import ConfigError
from foresight.core.evaluation.gates import GateCheck, GateResult
from foresight.core.runtime.execution import Execution, Executor
from foresight.core.runtime.refs import Seed
from foresight.core.training.proxy import ProxySpec
from foresight.core.yamlio import load_yaml


class _Strict(BoundedConfig):
    model_config = ConfigDict(extra="forbid")


class GateConfig(_Strict):
    max_val_ade: float = Field(default=1.0, gt=0)  #: [m]
    max_val_fde: float = Field(default=1.8, gt=0)  #: [m]
    require_beat_cv: bool = True  #: best val ADE and FDE must be below constant velocity's on the same split
    #: closed loop: the selected checkpoint's proxy success must not be below the same planner's with constant
    #: velocity on the same proxy episodes (reported whenever a proxy ran; a check only when true)
    require_proxy_not_below_cv: bool = False


class TrainConfig(_Strict):
    dataset: str  #: dataset id (resolved by the context) or a local .npz path
    epochs: int = Field(default=30, ge=1, le=10_000)
    batch_size: int = Field(default=512, ge=1, le=65_536)
    lr: float = Field(default=2e-3, gt=0, le=10.0)
    weight_decay: float = Field(default=1e-4, ge=0, le=10.0)
    lr_schedule: Literal["constant", "cosine"] = (
        "constant"  #: cosine: lr * (1 + cos(pi * (epoch - 1) / epochs)) / 2
    )
    seed: Seed = 0
    hidden: int = Field(
        default=48, ge=4, le=1024
    )  #: model width h (48: ~2.5 MFLOP per training sample at N=12)
    blocks: int = Field(default=2, ge=0, le=8)  #: K message-passing blocks
    edge_dim: int = Field(
        default=16, ge=0, le=256
    )  #: relative position/velocity edge embedding width (0 = none; core.predict.nn.model)
    local_frame: bool = True  #: encode/decode each pedestrian in its own frame (core.predict.nn.model)
    sigma_head: bool = (
        False  #: also predict a per-step spread (Gaussian NLL of the mean's error; core.predict.nn.model)
    )
    nll_weight: float = Field(
        default=0.1, gt=0
    )  #: weight of the spread's NLL in the loss (its head reads detached inputs)
    ensemble: int = Field(
        default=1, ge=1, le=16
    )  #: > 1: train that many members (seeds seed, seed+1, ...), each selected as usual; the checkpoint averages them
    loss: Literal["smooth_l1", "euclidean"] = (
        "smooth_l1"  #: euclidean: the mean displacement error itself (what ADE scores)
    )
    loss_beta: float = Field(default=0.2, gt=0)  #: SmoothL1 beta [m]
    grad_clip: float = Field(default=1.0, gt=0)
    augment_mirror: bool = False  #: mirror a random half of each batch across the ego x axis (y -> -y)
    augment_scale: tuple[float, float] | None = (
        None  #: scale each sample's lengths/speeds and targets by a factor drawn log-uniformly from [lo, hi]
    )
    #: up to this std [m] (drawn per sample) of Gaussian noise on every observed past position (the current one stays:
    #: it is the frame's origin), velocities recomputed from the noisy positions: teaches the model not to trust one
    #: step's velocity (annotated tracks jitter and stall); 0 = off
    augment_jitter: float = Field(default=0.0, ge=0, le=1)
    #: the trained model predicts the mean of its forecast and the mirror image of its forecast of the mirrored scene
    #: (twice the inference cost; training and checkpoint selection see the network alone). Only with
    #: augment_mirror: where the data keep a side (the simulator's walkers pass on one), the mirror twin forecasts
    #: a world that does not exist (the default model with it: stress suite 0.953 -> 0.906)
    mirror_average: bool = False
    #: K modes per pedestrian with weights (core.predict.nn.modes): mode 0 trained as without modes (the same weights
    #: for the same seed), K - 1 winner-takes-all modes and a weight head on its detached embedding; 1 = none
    modes: int = Field(default=1, ge=1, le=64)
    #: with modes: which mode forecasts rank most likely (best-of-1): first = mode 0, the deterministic trajectory;
    #: weight = the weight head's top mode (core.predict.nn.modes)
    mode_top: Literal["first", "weight"] = "first"
    threads: int = Field(
        default=1, ge=1, le=64
    )  #: torch intra-op threads (1: small matmuls gain little from more, and shared cores thrash)
    #: torch device of the model and data: auto = cuda when torch sees a GPU where training runs (a Ray task given
    #: one), else cpu; cuda without a GPU fails there (core.predict.nn.device); shuffling draws stay on the CPU
    device: Literal["auto", "cpu", "cuda"] = "auto"
    val_split: str = "val"  #: which recorded split validates (val; test only for held-out checks)
    proxy_every: int = Field(default=0, ge=0, le=10_000)  #: epochs between proxy evaluations (0 = off)
    proxy: ProxySpec | None = None  #: closed-loop proxy episodes (training hard seeds) when proxy_every > 0
    resume: bool = True  #: continue from checkpoints/last.pt in the work dir when present
    allow_degenerate: bool = False  #: skip the fail-fast dataset checks (recorded in the summary)
    gates: GateConfig = GateConfig()
    #: ray: training runs as one Ray task, on a GPU node when the cluster has one (core.jobs.ray_train)
    executor: Executor = "local"

    @field_validator("mirror_average")
    @classmethod
    def _mirror_needs_mirrored_data(cls, v: bool, info: ValidationInfo) -> bool:
        if v and not info.data.get("augment_mirror"):
            raise ValueError(
                "mirror_average needs augment_mirror: true (the model must have been trained on "
                "mirrored scenes for its mirror twin to be a forecast)"
            )
        return v

    @field_validator("augment_scale")
    @classmethod
    def _scale_bounds(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not 0 < v[0] <= v[1]:
            raise ValueError("augment_scale needs 0 < lo <= hi")
        return v


class TrainResult(BaseModel):
    checkpoint: str
    summary: str
    best_epoch: int
    val_ade: float
    val_fde: float
    cv_val_ade: float
    cv_val_fde: float
    selection_mode: str
    gates_passed: bool
    device: str | None = (
        None  #: the torch device that trained (cpu, cuda); None in results from before devices
    )
    execution: Execution | None = None  #: set when it ran as a Ray task: where, on how many CPUs/GPUs


class _Summary(BaseModel):
    model_config = ConfigDict(ser_json_inf_nan="constants")  #: a proxy clearance is -inf without pedestrians


class ProxyScore(_Summary):
    """A checkpoint's closed-loop proxy evaluation (core.training.proxy)."""

    success: float  #: success rate in [0, 1]
    clearance: float  #: mean minimum surface gap [m] (-inf without pedestrians)
    episodes: float | None = None
    cv_success: float | None = None  #: the same planner with constant velocity on the same episodes
    vs_cv_delta: float | None = None  #: success - cv_success (paired episodes)
    vs_cv_p: float | None = None  #: McNemar exact p of that difference


class EpochScore(_Summary):
    """The validation numbers a checkpoint is selected and gated by."""

    epoch: int
    val_loss: float
    val_ade: float
    val_fde: float
    proxy: ProxyScore | None = None


class EpochRecord(EpochScore):
    """One training epoch (a row of ``history``)."""

    train_loss: float
    train_ade: float
    train_fde: float
    cv_val_ade: float
    cv_val_fde: float
    train_runtime_s: float | None = None
    val_runtime_s: float | None = None
    train_samples: int | None = None
    val_samples: int | None = None
    val_nll: float | None = None  #: models with a sigma head: Gaussian NLL of the validation points
    val_cover1: float | None = (
        None  #: fraction of validation truths within 1 sigma of the mean (calibrated: 0.393)
    )
    val_cover2: float | None = None  #: ... within 2 sigma (calibrated: 0.865)
    val_min_ade: float | None = (
        None  #: models with modes: minADE over all K modes of the validation pedestrians
    )
    val_min_fde: float | None = None  #: ... minFDE


class EnsembleScore(EpochScore):
    """An ensemble's validation numbers (``epoch``: its latest member's)."""

    member_epochs: list[int]


class AdeFde(_Summary):
    ade: float
    fde: float


class TrainingGate(_Summary):
    """The training gate: the selected checkpoint's validation ADE/FDE against limits and constant velocity."""

    limits: GateConfig
    cv: AdeFde
    checks: dict[str, bool]  #: val_ade_below_limit, val_fde_below_limit, val_ade_below_cv, val_fde_below_cv
    passed: bool
    closed_loop: ProxyScore | None = (
        None  #: the selected checkpoint's proxy score (with CV on the same episodes)
    )

    def reference(self, best: EpochScore) -> dict[str, tuple[float | None, float | None]]:
        """Check name -> (value, threshold) ([m]; the closed-loop check: success rates)."""
        p = self.closed_loop
        return {
            "val_ade_below_limit": (best.val_ade, self.limits.max_val_ade),
            "val_fde_below_limit": (best.val_fde, self.limits.max_val_fde),
            "val_ade_below_cv": (best.val_ade, self.cv.ade),
            "val_fde_below_cv": (best.val_fde, self.cv.fde),
            "proxy_success_not_below_cv": (p.success if p else None, p.cv_success if p else None),
        }


def training_gate(gates: GateConfig, best: EpochScore, cv: AdeFde) -> TrainingGate:
    checks = {
        "val_ade_below_limit": best.val_ade <= gates.max_val_ade,
        "val_fde_below_limit": best.val_fde <= gates.max_val_fde,
        "val_ade_below_cv": (best.val_ade < cv.ade) or not gates.require_beat_cv,
        "val_fde_below_cv": (best.val_fde < cv.fde) or not gates.require_beat_cv,
    }
    if gates.require_proxy_not_below_cv:  # closed loop, paired on the proxy episodes (core.training.proxy)
        delta = best.proxy.vs_cv_delta if best.proxy is not None else None
        checks["proxy_success_not_below_cv"] = delta is not None and delta >= 0.0
    return TrainingGate(
        limits=gates, cv=cv, checks=checks, passed=all(checks.values()), closed_loop=best.proxy
    )


class EnsembleMember(_Summary):
    seed: int
    summary: str  #: the member's training_summary.json, relative to the ensemble's folder
    best_epoch: int
    val_ade: float
    val_fde: float


class SelectionState(_Summary):
    """How the checkpoint was selected (core.predict.nn.selection.Selection without its copy of the best epoch)."""

    proxy_enabled: bool
    mode: str  #: val_loss | val_loss_fallback | proxy
    reason: str
    proxy_history: list[dict[str, float]]


class TrainingSummary(_Summary):
    """``training_summary.json`` of the ``train`` stage (one run or an ensemble); the TrainResult is derived from it."""

    artifact_role: Literal["predictive_training_summary"] = "predictive_training_summary"
    config: dict  #: the TrainConfig as run
    dataset: dict  #: id, sha256, source, generator config hash, frame convention, lineage
    dataset_stats: dict
    cv_val: AdeFde
    history: list[EpochRecord]
    best: EpochRecord | EnsembleScore
    selection: SelectionState | None = None  #: single runs only
    members: list[EnsembleMember] | None = None  #: ensembles only
    selection_mode: str
    quality_gates: TrainingGate
    checkpoint: str
    total_runtime_s: float
    code_version: str
    device: str | None = None  #: the torch device that trained (cpu, cuda; config.device is what was asked)

    def gate_result(self) -> GateResult:
        """The training gate as a GateResult (each check with its value and threshold)."""
        ref = self.quality_gates.reference(self.best)
        return GateResult(
            passed=self.quality_gates.passed,
            checks=[
                GateCheck(name=name, passed=ok, value=ref[name][0], threshold=ref[name][1])
                for name, ok in self.quality_gates.checks.items()
            ],
        )

    def result(self, path: str) -> TrainResult:
        """The stage result of this summary, written at ``path``."""
        return TrainResult(
            checkpoint=self.checkpoint,
            summary=path,
            best_epoch=self.best.epoch,
            val_ade=self.best.val_ade,
            val_fde=self.best.val_fde,
            cv_val_ade=self.cv_val.ade,
            cv_val_fde=self.cv_val.fde,
            selection_mode=self.selection_mode,
            gates_passed=self.quality_gates.passed,
            device=self.device,
        )


def load_config(path: Path, model: type[BaseModel], key: str | None = None) -> BaseModel:
    """Read a YAML file (optionally one top-level ``key`` of it) into ``model``; errors name file and field."""
    try:
        data = load_yaml(Path(path).read_text(), source=path)
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"cannot read YAML ({exc})", source=path) from None
    if key is not None:
        data = (data or {}).get(key)
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        raise ConfigError(err["msg"], source=path, item=".".join(str(p) for p in err["loc"])) from None
