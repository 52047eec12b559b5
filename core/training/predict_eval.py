"""Stage ``predict_eval``: a predictor (constant velocity, a checkpoint, a predictor plug-in, or a model trained
per fold) on ETH/UCY leave-one-scene-out folds or on a dataset's held-out split, always next to constant velocity
on the same samples: best-of-1 ADE/FDE, minADE_K/minFDE_K, and NLL and calibration where a spread is given
(``forecast_metrics``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from foresight.core.bounds import BoundedConfig
from foresight.core.errors import ConfigError
from foresight.core.predict import forecast_metrics
from foresight.core.predict.dataset import Dataset, load_dataset, resolve_dataset_path, save_dataset
from foresight.core.predict.ethucy import FOLDS, import_fold
from foresight.core.predict.metrics import ade_fde, evaluate_predictor
from foresight.core.predict.plugin import PluginForecaster
from foresight.core.predict.plugin_eval import plugin_forecasts
from foresight.core.predict.predictor import ConstantVelocityPredictor, StaticPredictor
from foresight.core.predict.timebase import ETHUCY_TIMEBASE
from foresight.core.runtime.context import StageContext

#: the stage's own keys that a training config file (``configs/training/ethucy.yaml``) may hold beside its ``train``
#: mapping: what each fold trains on, where ``train`` says how
FILE_KEYS = ("reverse_train",)


class PredictEvalConfig(BoundedConfig):
    model_config = ConfigDict(extra="forbid", frozen=True)
    #: "cv", "static", a model id, a predictor plug-in name (docs/predictor_protocol.md), or (in-process runs) a checkpoint path
    model: str | None = None
    best_of: int = Field(default=20, ge=1, le=1000)  #: K of minADE_K / minFDE_K (the field's convention: 20)
    train: dict[str, Any] | None = None  #: TrainConfig fields (without dataset): train one model per fold
    ethucy: str | None = (
        None  #: named data root (FORESIGHT_DATA_ROOTS) holding <fold>/train|val|test; in-process
    )
    #: runs also take a directory
    folds: list[str] | None = None  #: default: all five
    dataset: str | None = None  #: dataset id or .npz path (instead of ethucy)
    #: your own recordings (``scene_import.ImportScenesConfig`` fields; in-process runs): leave-one-scene-out
    scenes: dict[str, Any] | None = None
    split: str = "test"  #: held-out split of ``dataset`` (test, else val when it has no test episodes; "all")
    max_agents: int = Field(default=12, ge=1, le=256)  #: slots per ETH/UCY sample
    #: ETH/UCY with ``train``: each fold also trains on its training scenes played backwards (twice the windows;
    #: people walk much alike either way). Validation and test stay as recorded. 5-fold average, one member each
    #: (2026-11-29): 0.4683 -> 0.4624 ADE, every fold lower
    reverse_train: bool = False

    @model_validator(mode="after")
    def _one_each(self) -> PredictEvalConfig:
        if (self.model is None) == (self.train is None):
            raise ValueError("give exactly one of model (cv | checkpoint) and train")
        if sum(x is not None for x in (self.ethucy, self.dataset, self.scenes)) != 1:
            raise ValueError("give exactly one of ethucy, dataset and scenes")
        if self.scenes is not None:
            from foresight.core.predict.scene_import import ImportScenesConfig

            ImportScenesConfig.model_validate(self.scenes)
        if self.reverse_train and (self.train is None or self.ethucy is None):
            raise ValueError(
                "reverse_train plays ETH/UCY training scenes backwards: it needs train and ethucy"
            )
        if self.train is not None:
            _check_train(self.train)
        return self


def _check_train(train: dict[str, Any]) -> None:
    """Refuse ``train`` fields that training would refuse, before any fold is imported or trained (the dataset is
    each fold's own, so it is not checked here)."""
    from foresight.core.training.config import TrainConfig

    try:
        TrainConfig.model_validate({**train, "dataset": "fold"})
    except ValidationError as exc:
        err = exc.errors()[0]
        key = ".".join(str(p) for p in err["loc"])
        hint = f" ({key} belongs beside the train mapping, not in it)" if key in FILE_KEYS else ""
        raise ValueError(f"train.{key}: {err['msg']}{hint}") from None


class Score(BaseModel):
    ade: float  #: [m] best-of-1: the most likely mode's
    fde: float  #: [m]
    best_of: int | None = None  #: K of min_ade / min_fde (fewer when the predictor gives fewer modes)
    min_ade: float | None = None  #: [m] minADE_K: the best of the K most likely modes
    min_fde: float | None = None  #: [m] minFDE_K
    nll: float | None = None  #: [nats] mean negative log-likelihood of the true positions (a spread is given)
    within_1sigma: float | None = (
        None  #: share of true positions within 1 sigma of the most likely mode (0.393)
    )
    within_2sigma: float | None = None  #: ... within 2 sigma (0.865 when calibrated)
    #: K asked of minADE_K / minFDE_K; where it exceeds ``best_of``, the minimum is over every mode the predictor has
    best_of_asked: int | None = None
    #: [m] predictors with several modes: the first mode's ADE / FDE (a network with modes puts its deterministic
    #: trajectory there, ``core.predict.nn.modes``); ``ade`` / ``fde`` are the most likely mode's (largest weight)
    first_ade: float | None = None
    first_fde: float | None = None


class FoldScore(Score):
    samples: int
    split: str  #: the split scored
    cv_ade: float
    cv_fde: float
    predictor: str
    modes: int = 1  #: modes the predictor gave per pedestrian


class PredictEvalResult(BaseModel):
    folds: dict[str, FoldScore]
    average: Score
    cv_average: Score


def _predictor(config: PredictEvalConfig, ds: Dataset, ctx: StageContext, name: str):
    from foresight.core.predict import plugins

    if config.model == "cv":
        return ConstantVelocityPredictor(ds.meta.timebase)
    if config.model == "static":
        return StaticPredictor(ds.meta.timebase)
    if plugins.kind(config.model):
        return plugins.load(config.model)
    if config.model is not None:
        from foresight.core.predict import registered
        from foresight.core.predict.nn.checkpoint import load_predictor

        path = ctx.local_file(config.model) or ctx.resolve_model(config.model)
        if registered.is_registered(path):  # a registered plug-in or external model (its files checked)
            return plugins.load(registered.predictor_name(path), registered.files_dir(path))
        return load_predictor(path, expect_timebase=ds.meta.timebase)
    from foresight.core.predict.nn.checkpoint import load_predictor
    from foresight.core.training.config import TrainConfig
    from foresight.core.training.train import run_train

    data_path = ctx.artifact(f"{name}/dataset.npz")
    save_dataset(ds, data_path)
    sub = StageContext(
        workdir=ctx.artifact(f"{name}/train/.keep").parent,
        log=ctx.log,
        is_cancelled=ctx.is_cancelled,
        progress=lambda f, m: ctx.progress(f, f"{name}: {m}"),
        local_files=True,
    )  # the fold's dataset: the file this stage just wrote
    result = run_train(TrainConfig(**{**config.train, "dataset": str(data_path)}), sub)
    return load_predictor(Path(result.checkpoint), expect_timebase=ds.meta.timebase)


def _score(config: PredictEvalConfig, ds: Dataset, split: str, ctx: StageContext, name: str) -> FoldScore:
    if split == "all":
        if config.train is not None:
            raise ConfigError(
                "split 'all' cannot be used with training (it would score training data)",
                source=name,
                item="split",
            )
        ds = _all_as_test(ds)
        split = "test"
    if not len(ds.split_indices(split)):
        raise ConfigError(f"no samples in split {split!r}", source=name, item="split")
    predictor = _predictor(config, ds, ctx, name)
    modes, weights, spread = _forecasts(predictor, ds, split)
    idx = ds.split_indices(split)
    r = forecast_metrics.score(modes, weights, ds.target[idx], ds.target_mask[idx], spread, config.best_of)
    cv = evaluate_predictor(ConstantVelocityPredictor(ds.meta.timebase), ds, split)
    first = {}
    if modes.shape[2] > 1:
        f = ade_fde(modes[:, :, 0], ds.target[idx], ds.target_mask[idx])
        first = {"first_ade": f["ade"], "first_fde": f["fde"]}
    return FoldScore(
        **{k: r[k] for k in Score.model_fields if k in r},
        **first,
        best_of_asked=config.best_of,
        samples=len(idx),
        split=split,
        cv_ade=cv["ade"],
        cv_fde=cv["fde"],
        predictor=getattr(predictor, "who", None) or getattr(predictor, "name", "model"),
        modes=int(modes.shape[2]),
    )


def _forecasts(predictor, ds: Dataset, split: str, batch: int = 4096):
    """Modes (S, N, K, T, 2), weights (S, N, K) and spread (or None) of any predictor on a split's samples."""
    idx = ds.split_indices(split)
    if isinstance(predictor, PluginForecaster):
        return plugin_forecasts(predictor, ds.state[idx], ds.mask[idx], ds.meta.timebase)
    predictor.timebase.require_same(ds.meta.timebase, what="dataset")
    dist = getattr(predictor, "has_sigma", False)
    k = int(getattr(predictor, "n_modes", 1))
    pos, wts, sig = [], [], []
    for i in range(0, len(idx), batch):
        part = idx[i : i + batch]
        if k > 1:
            p, w = predictor.predict_modes(ds.state[part], ds.mask[part])
            wts.append(w)
        if dist:  # mode 0's spread; a model with modes gives every mode its mode 0's
            p0, s = predictor.predict_dist(ds.state[part], ds.mask[part])
            sig.append(np.repeat(s[:, :, None], k, axis=2))
        else:
            p0 = predictor.predict(ds.state[part], ds.mask[part]) if k == 1 else None
        pos.append(p if k > 1 else p0[:, :, None])
    shape = (0, *ds.target.shape[1:])
    modes = np.concatenate(pos) if pos else np.zeros((0, shape[1], k, *shape[2:]), np.float32)
    weights = np.concatenate(wts) if wts else np.ones(modes.shape[:3])
    spread = (np.concatenate(sig) if sig else np.zeros(modes.shape[:-1])) if dist else None
    return modes, weights, spread


def _all_as_test(ds: Dataset) -> Dataset:
    """The same samples with every episode marked test (a dataset collected only for evaluation)."""
    from dataclasses import replace

    meta = replace(ds.meta, episodes=[replace(e, split="test") for e in ds.meta.episodes])
    return Dataset(ds.state, ds.target, ds.mask, ds.target_mask, ds.episode, meta)


def run_predict_eval(config: PredictEvalConfig, ctx: StageContext) -> PredictEvalResult:
    folds: dict[str, FoldScore] = {}
    if config.ethucy is not None:
        local = Path(config.ethucy)
        root = local if ctx.local_files and local.is_dir() else ctx.resolve_data_root(config.ethucy)
        names = config.folds or list(FOLDS)
        splits = ("test",) if config.train is None else ("train", "val", "test")
        for i, fold in enumerate(names):
            ctx.check_cancelled()
            ctx.progress(i / len(names), f"fold {fold}")
            ds = import_fold(
                root,
                fold,
                ETHUCY_TIMEBASE,
                config.max_agents,
                splits,
                reversed_splits=("train",) if config.reverse_train else (),
            )
            folds[fold] = _score(config, ds, "test", ctx, fold)
    elif config.scenes is not None:
        from foresight.core.predict.scene_import import ImportScenesConfig, read_scenes, scene_folds

        if not ctx.local_files:
            raise ConfigError("scenes are local files: run predict-eval in-process", item="scenes")
        scene_config = ImportScenesConfig.model_validate(config.scenes)
        for name, ds in scene_folds(read_scenes(scene_config), scene_config):
            ctx.check_cancelled()
            ctx.progress(len(folds) / max(1, len(folds) + 1), f"scene {name}")
            folds[name] = _score(config, ds, "test", ctx, name)
    else:
        path = resolve_dataset_path(config.dataset, ctx)
        ds = load_dataset(path)
        split = config.split if len(ds.split_indices(config.split)) or config.split != "test" else "val"
        folds[Path(path).stem] = _score(config, ds, split, ctx, Path(path).stem)
    ctx.progress(1.0, "done")
    mean = lambda key: float(np.mean([getattr(f, key) for f in folds.values()]))  # noqa: E731
    opt = {
        key: (mean(key) if all(getattr(f, key) is not None for f in folds.values()) else None)
        for key in ("min_ade", "min_fde", "nll", "within_1sigma", "within_2sigma", "first_ade", "first_fde")
    }
    return PredictEvalResult(
        folds=folds,
        average=Score(
            ade=mean("ade"),
            fde=mean("fde"),
            best_of=min(f.best_of for f in folds.values()),
            best_of_asked=config.best_of,
            **opt,
        ),
        cv_average=Score(ade=mean("cv_ade"), fde=mean("cv_fde")),
    )
