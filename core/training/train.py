"""Training the graph predictor: a linear ``train()`` in the nanoGPT spirit.

Data come from one dataset file, split by episode (recorded in the dataset). Each epoch: one pass
over shuffled training samples (order seeded by (seed, epoch), so a resumed run repeats the same
batches), then validation loss/ADE/FDE, ``checkpoints/last.pt`` (with optimizer state, for resume),
optional proxy evaluation through a callback, and selection. The selected model is written to
``model.pt``; ``training_summary.json`` records history, selection, gates and dataset statistics.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from foresight.core import files
from foresight.core.errors import ConfigError
from foresight.core.predict.dataset import Dataset, file_sha256, load_dataset, resolve_dataset_path
from foresight.core.predict.features import STEP_CHANNELS, length_channels, mirror_signs
from foresight.core.predict.metrics import ade_fde
from foresight.core.predict.nn.checkpoint import make_checkpoint, read_checkpoint, save_checkpoint
from foresight.core.predict.nn.device import resolve_device, to_cpu
from foresight.core.predict.nn.model import (
    EnsembleModel,
    ModelConfig,
    TrajectoryModel,
    masked_ade_fde,
    masked_gaussian_nll,
    masked_loss,
)
from foresight.core.predict.nn.modes import mode_errors, mode_loss
from foresight.core.predict.nn.selection import Selection
from foresight.core.predict.predictor import ConstantVelocityPredictor
from foresight.core.predict.quality import check_quality, summarize
from foresight.core.runtime.context import StageContext
from foresight.core.training.config import (
    AdeFde,
    EnsembleMember,
    EnsembleScore,
    EpochRecord,
    SelectionState,
    TrainConfig,
    TrainingSummary,
    TrainResult,
    training_gate,
)
from foresight.core.version import code_version

_CHECKPOINT_METRICS = (
    "val_loss",
    "val_ade",
    "val_fde",
    "val_nll",
    "val_cover1",
    "val_cover2",
    "val_min_ade",
    "val_min_fde",
)

#: proxy evaluation: checkpoint path -> {"success": rate in [0, 1], "clearance": mean min distance [m]}
ProxyCallback = Callable[[Path], dict[str, float]]


def _tensors(ds: Dataset, index: np.ndarray, device: torch.device) -> dict[str, torch.Tensor]:
    return {
        k: torch.from_numpy(np.ascontiguousarray(getattr(ds, k)[index])).to(device)
        for k in ("state", "mask", "target", "target_mask")
    }


def evaluate(
    model: TrajectoryModel,
    data: dict[str, torch.Tensor],
    beta: float,
    batch: int = 2048,
    loss: str = "smooth_l1",
) -> dict[str, float]:
    """Loss, ADE, FDE over a whole split (sums over valid points, not means of batch means)."""
    model.eval()
    loss_sum = err = pts = ferr = fin = 0.0
    spread = getattr(model.config, "sigma_head", False)
    nll_sum = in1 = in2 = min_err = min_ferr = 0.0
    with torch.inference_mode():
        for i in range(0, len(data["state"]), batch):
            b = {k: v[i : i + batch] for k, v in data.items()}
            if spread:
                pred, sigma = model.forward_dist(b["state"], b["mask"])
                n = float(b["target_mask"].sum())
                nll_sum += float(masked_gaussian_nll(pred, sigma, b["target"], b["target_mask"])) * n
                r = torch.linalg.vector_norm(pred - b["target"], dim=-1) / sigma  # error in sigmas
                in1 += float(((r <= 1.0) * b["target_mask"]).sum())
                in2 += float(((r <= 2.0) * b["target_mask"]).sum())
            else:
                pred = model(b["state"], b["mask"])
            if (
                getattr(model, "mode_head", None) is not None
            ):  # best of the K modes, each pedestrian on its own
                modes = model.forward_modes(b["state"], b["mask"])[0]
                tm = b["target_mask"]
                min_err += float((mode_errors(modes, b["target"], tm).min(-1).values * tm.sum(-1)).sum())
                fin_err = torch.linalg.vector_norm(modes[..., -1, :] - b["target"][..., None, -1, :], dim=-1)
                min_ferr += float((fin_err.min(-1).values * tm[..., -1]).sum())
            loss_sum += float(masked_loss(loss, pred, b["target"], b["target_mask"], beta)) * float(
                b["target_mask"].sum()
            )
            e, p, fe, f = masked_ade_fde(pred, b["target"], b["target_mask"])
            err, pts, ferr, fin = err + float(e), pts + float(p), ferr + float(fe), fin + float(f)
    out = {"loss": loss_sum / max(pts, 1.0), "ade": err / max(pts, 1.0), "fde": ferr / max(fin, 1.0)}
    if spread:  # a calibrated 2D Gaussian holds 39.3 % of truths within 1 sigma, 86.5 % within 2
        out.update(nll=nll_sum / max(pts, 1.0), cover1=in1 / max(pts, 1.0), cover2=in2 / max(pts, 1.0))
    if (
        getattr(model, "mode_head", None) is not None
    ):  # min over modes of each pedestrian's ADE, point-weighted
        out.update(min_ade=min_err / max(pts, 1.0), min_fde=min_ferr / max(fin, 1.0))
    return out


def train_epoch(
    model, opt, data: dict[str, torch.Tensor], config: TrainConfig, epoch: int
) -> dict[str, float]:
    """One pass in shuffled batches on the data's device; every random draw comes from one CPU generator seeded by
    (seed, epoch), so the batches and augmentations are the same on any device."""
    model.train()
    device = data["state"].device
    gen = torch.Generator().manual_seed(config.seed * 1_000_003 + epoch)
    order = torch.randperm(len(data["state"]), generator=gen).to(device)
    signs = torch.from_numpy(mirror_signs(model.config.history)).to(device) if config.augment_mirror else None
    lengths = (
        torch.from_numpy(length_channels(model.config.history)).to(device) if config.augment_scale else None
    )
    loss_sum = err = pts = ferr = fin = 0.0
    for i in range(0, len(order), config.batch_size):
        idx = order[i : i + config.batch_size]
        b = {k: v[idx] for k, v in data.items()}
        if signs is not None:
            b = _mirror_half(b, signs, gen)
        if lengths is not None:
            b = _scale(b, lengths, config.augment_scale, gen)
        if config.augment_jitter > 0:
            b = _jitter(b, config.augment_jitter, model.config.history, model.config.dt, gen)
        modes = head_loss = None
        if model.mode_head is not None:
            out = model.forward_modes(b["state"], b["mask"], with_sigma=config.sigma_head)
            modes, logits, pred = out[0], out[1], out[0][:, :, 0]
            sigma = out[2] if config.sigma_head else None
            head_loss = mode_loss(modes, logits, b["target"], b["target_mask"])
        elif config.sigma_head:
            pred, sigma = model.forward_dist(b["state"], b["mask"])
        else:
            pred = model(b["state"], b["mask"])
        loss = masked_loss(config.loss, pred, b["target"], b["target_mask"], config.loss_beta)
        if config.sigma_head:
            loss = loss + config.nll_weight * masked_gaussian_nll(pred, sigma, b["target"], b["target_mask"])
        opt.zero_grad(set_to_none=True)
        (loss if head_loss is None else loss + head_loss).backward()
        torch.nn.utils.clip_grad_norm_(_network_params(model), config.grad_clip, error_if_nonfinite=True)
        if head_loss is not None:  # clipped apart: the head's gradients never scale the network's
            torch.nn.utils.clip_grad_norm_(
                model.mode_head.parameters(), config.grad_clip, error_if_nonfinite=True
            )
        opt.step()
        with torch.no_grad():
            e, p, fe, f = masked_ade_fde(pred, b["target"], b["target_mask"])
        n = float(b["target_mask"].sum())
        loss_sum, err, pts, ferr, fin = (
            loss_sum + float(loss.detach()) * n,
            err + float(e),
            pts + float(p),
            ferr + float(fe),
            fin + float(f),
        )
    return {"loss": loss_sum / max(pts, 1.0), "ade": err / max(pts, 1.0), "fde": ferr / max(fin, 1.0)}


def _network_params(model: TrajectoryModel) -> list[torch.nn.Parameter]:
    """The parameters besides the mode head (``core.predict.nn.modes``), in registration order."""
    return [p for name, p in model.named_parameters() if not name.startswith("mode_head.")]


def _mirror_half(
    b: dict[str, torch.Tensor], signs: torch.Tensor, gen: torch.Generator
) -> dict[str, torch.Tensor]:
    """Mirror a random half of the batch across the ego x axis (features by ``signs``, targets' y)."""
    flip = torch.rand(len(b["state"]), generator=gen).to(b["state"].device) < 0.5
    out = dict(b)
    out["state"] = torch.where(flip[:, None, None], b["state"] * signs, b["state"])
    ty = torch.where(flip[:, None, None], -b["target"][..., 1], b["target"][..., 1])
    out["target"] = torch.stack([b["target"][..., 0], ty], dim=-1)
    return out


def _scale(
    b: dict[str, torch.Tensor], lengths: torch.Tensor, bounds: tuple[float, float], gen: torch.Generator
) -> dict[str, torch.Tensor]:
    """Every sample's length channels and targets times one factor, log-uniform in ``bounds``."""
    lo, hi = math.log(bounds[0]), math.log(bounds[1])
    f = torch.exp(lo + (hi - lo) * torch.rand(len(b["state"]), generator=gen).to(b["state"].device))[
        :, None, None
    ]
    return {**b, "state": b["state"] * (1.0 + (f - 1.0) * lengths), "target": b["target"] * f[..., None]}


def _jitter(
    b: dict[str, torch.Tensor], std: float, history: int, dt: float, gen: torch.Generator
) -> dict[str, torch.Tensor]:
    """Gaussian noise on every valid past position of every slot, the current one kept (the ego frame's origin), its
    standard deviation drawn per sample uniformly from [0, ``std``] [m] (clean and noisy tracks alike, so the model
    can tell them apart by their history); each step's velocity recomputed as the features define it
    ((p[h] - p[h-1]) / dt where both are valid)."""
    state, width = b["state"], len(STEP_CHANNELS) * history  # per step: px, py, vx, vy, valid
    B, N, _ = state.shape
    step = state[..., :width].reshape(B, N, history, len(STEP_CHANNELS))
    valid = step[..., STEP_CHANNELS.index("valid")]
    scale = std * torch.rand((B, 1, 1, 1), generator=gen)
    noise = (scale * torch.randn((B, N, history, 2), generator=gen)).to(state.device)
    noise[:, :, -1] = 0.0
    pos = step[..., :2] + noise * valid[..., None]
    both = valid[..., 1:] * valid[..., :-1]
    vel = torch.zeros_like(pos)
    vel[:, :, 1:] = (pos[:, :, 1:] - pos[:, :, :-1]) / dt * both[..., None]
    step = torch.cat([pos, vel, valid[..., None]], dim=-1).reshape(B, N, width)
    return {**b, "state": torch.cat([step, state[..., width:]], dim=-1)}


def epoch_lr(config: TrainConfig, epoch: int) -> float:
    """Learning rate of an epoch (a pure function of the epoch, so resuming continues the schedule)."""
    if config.lr_schedule == "cosine":
        return config.lr * 0.5 * (1.0 + math.cos(math.pi * (epoch - 1) / config.epochs))
    return config.lr


def cv_metrics(ds: Dataset, index: np.ndarray) -> dict[str, float]:
    pred = ConstantVelocityPredictor(ds.meta.timebase).predict(ds.state[index], ds.mask[index])
    r = ade_fde(pred, ds.target[index], ds.target_mask[index])
    return {"ade": r["ade"], "fde": r["fde"]}


def run_train(config: TrainConfig, ctx: StageContext, proxy: ProxyCallback | None = None) -> TrainResult:
    """Train on ``config.dataset``; resume from ``checkpoints/last.pt`` in the work dir when present."""
    device = resolve_device(config.device)  # first: cuda without a GPU fails before anything is loaded
    if config.ensemble > 1:
        return _train_ensemble(config, ctx, proxy, device)
    started = time.time()
    torch.set_num_threads(config.threads)
    if proxy is None and config.proxy is not None and config.proxy_every > 0:
        from foresight.core.training.proxy import evaluation_proxy

        proxy = evaluation_proxy(config.proxy, ctx)
    ds_path = resolve_dataset_path(config.dataset, ctx)
    ds = load_dataset(ds_path)
    stats = summarize(ds) if config.allow_degenerate else check_quality(ds, str(ds_path))
    tr_idx, va_idx = ds.split_indices("train"), ds.split_indices(config.val_split)
    train_data, val_data = _tensors(ds, tr_idx, device), _tensors(ds, va_idx, device)
    cv = cv_metrics(ds, va_idx)
    tb = ds.meta.timebase
    mcfg = ModelConfig(
        tb.history,
        tb.horizon,
        tb.dt,
        config.hidden,
        config.blocks,
        config.edge_dim,
        config.local_frame,
        sigma_head=config.sigma_head,
        mirror_average=config.mirror_average,
        modes=config.modes,
        mode_top=config.mode_top,
    )
    with torch.random.fork_rng():
        torch.manual_seed(config.seed)
        model = TrajectoryModel(mcfg).to(device)  # initialised on the CPU: the same weights on any device
    opt = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    dataset_info = {
        "id": config.dataset,
        "sha256": file_sha256(ds_path),
        "source": ds.meta.source,
        "config_hash": ds.meta.generator_config_hash,
        "max_agents": ds.meta.max_agents,
        "frame_convention": ds.meta.frame_convention,
        "lineage": ds.meta.lineage,
        "timebase": ds.meta.timebase.to_dict(),
        **(
            {"scenes": scenes} if (scenes := ds.meta.recorded_scenes()) else {}
        ),  # real data: what it has seen
    }
    history, selection, start = [], Selection(proxy_enabled=proxy is not None and config.proxy_every > 0), 1
    last_path = ctx.artifact("checkpoints/last.pt")
    if config.resume and last_path.is_file():
        state = read_checkpoint(last_path)
        if (
            state["dataset"].get("sha256") != dataset_info["sha256"]
            or ModelConfig(**state["model_config"]) != mcfg
        ):
            raise ConfigError(
                "cannot resume: checkpoints/last.pt was trained on another dataset or model config "
                "(use a new work dir or resume: false)",
                source=last_path,
                item="resume",
            )
        model.load_state_dict(state["model"])
        opt.load_state_dict(state["optimizer"])
        history, start = state["train_state"]["history"], state["epoch"] + 1
        selection = Selection.from_dict(state["train_state"]["selection"])
        ctx.log(f"resumed after epoch {state['epoch']}")
    for epoch in range(start, config.epochs + 1):
        ctx.check_cancelled()
        t0 = time.time()
        for group in opt.param_groups:
            group["lr"] = epoch_lr(config, epoch)
        tr = train_epoch(model, opt, train_data, config, epoch)
        t1 = time.time()
        va = evaluate(model, val_data, config.loss_beta, loss=config.loss)
        rec = {
            "epoch": epoch,
            **{f"train_{k}": v for k, v in tr.items()},
            **{f"val_{k}": v for k, v in va.items()},
            "cv_val_ade": cv["ade"],
            "cv_val_fde": cv["fde"],
            "train_runtime_s": t1 - t0,
            "val_runtime_s": time.time() - t1,
            "train_samples": len(tr_idx),
            "val_samples": len(va_idx),
        }
        payload = make_checkpoint(
            model,
            tb,
            ds.meta.frame_convention,
            dataset_info,
            {k: v for k, v in rec.items() if k in _CHECKPOINT_METRICS},
            epoch,
        )
        if selection.proxy_enabled and epoch % config.proxy_every == 0:
            path = ctx.artifact(f"proxy_checkpoints/epoch_{epoch:04d}.pt")
            save_checkpoint(payload, path)
            rec["proxy"] = dict(proxy(path))
            payload["metrics"]["proxy"] = rec["proxy"]
        history.append(rec)
        if selection.offer(rec):
            save_checkpoint({**payload, "selection": selection.to_dict()}, ctx.artifact("model.pt"))
        save_checkpoint(
            {
                **payload,
                "optimizer": to_cpu(opt.state_dict()),
                "train_state": {"history": history, "selection": selection.to_dict()},
            },
            last_path,
        )
        ctx.progress(epoch / config.epochs, f"epoch {epoch}: val ade {va['ade']:.3f} fde {va['fde']:.3f}")
    return _finish(config, ctx, history, selection, cv, stats, dataset_info, started, device)


def _train_ensemble(
    config: TrainConfig, ctx: StageContext, proxy: ProxyCallback | None, device: torch.device
) -> TrainResult:
    """Members in ``members/<k>/`` (complete, resumable runs with seeds seed + k, each selected as usual), then
    ``model.pt`` averaging them and a summary with the ensemble's validation metrics and gates (``history``: the
    first member's curves; every member's summary is in its folder)."""
    started = time.time()
    k_total = config.ensemble
    results = []
    for k in range(k_total):
        sub = replace(
            ctx,
            workdir=ctx.artifact(f"members/{k}/.keep").parent,
            progress=lambda f, m, k=k: ctx.progress((k + f) / k_total, f"member {k + 1}/{k_total}: {m}"),
        )
        results.append(
            run_train(config.model_copy(update={"ensemble": 1, "seed": config.seed + k}), sub, proxy)
        )
    payloads = [read_checkpoint(Path(r.checkpoint)) for r in results]
    model = EnsembleModel(ModelConfig(**{**payloads[0]["model_config"], "members": k_total}))
    for member, payload in zip(model.members, payloads, strict=True):
        member.load_state_dict(payload["model"])
    ds_path = resolve_dataset_path(config.dataset, ctx)
    ds = load_dataset(ds_path)
    va_idx = ds.split_indices(config.val_split)
    va = evaluate(model.to(device), _tensors(ds, va_idx, device), config.loss_beta, loss=config.loss)
    cv = cv_metrics(ds, va_idx)
    best = EnsembleScore(
        epoch=max(r.best_epoch for r in results),
        val_loss=va["loss"],
        val_ade=va["ade"],
        val_fde=va["fde"],
        member_epochs=[r.best_epoch for r in results],
    )
    cv_val = AdeFde(**cv)
    payload = make_checkpoint(
        model,
        ds.meta.timebase,
        ds.meta.frame_convention,
        payloads[0]["dataset"],
        {"val_loss": best.val_loss, "val_ade": best.val_ade, "val_fde": best.val_fde},
        best.epoch,
    )
    save_checkpoint(payload, ctx.artifact("model.pt"))
    first = TrainingSummary.model_validate_json(Path(results[0].summary).read_text())
    summary = TrainingSummary(
        config=config.model_dump(),
        dataset=payloads[0]["dataset"],
        dataset_stats=first.dataset_stats,
        cv_val=cv_val,
        history=first.history,
        best=best,
        members=[
            EnsembleMember(
                seed=config.seed + k,
                summary=f"members/{k}/training_summary.json",
                best_epoch=r.best_epoch,
                val_ade=r.val_ade,
                val_fde=r.val_fde,
            )
            for k, r in enumerate(results)
        ],
        selection_mode=f"ensemble of {k_total} ({results[0].selection_mode} each)",
        quality_gates=training_gate(config.gates, best, cv_val),
        checkpoint=str(ctx.artifact("model.pt")),
        total_runtime_s=time.time() - started,
        code_version=code_version(),
        device=device.type,
    )
    return _write_summary(summary, ctx)


def _finish(config, ctx, history, selection, cv, stats, dataset_info, started, device) -> TrainResult:
    best, cv_val = EpochRecord.model_validate(selection.best), AdeFde(**cv)
    summary = TrainingSummary(
        config=config.model_dump(),
        dataset=dataset_info,
        dataset_stats=stats,
        cv_val=cv_val,
        history=history,
        best=best,
        selection=SelectionState.model_validate(selection.to_dict()),
        selection_mode=selection.mode,
        quality_gates=training_gate(config.gates, best, cv_val),
        checkpoint=str(ctx.artifact("model.pt")),
        total_runtime_s=time.time() - started,
        code_version=code_version(),
        device=device.type,
    )
    return _write_summary(summary, ctx)


def _write_summary(summary: TrainingSummary, ctx: StageContext) -> TrainResult:
    """Write ``training_summary.json`` (one run or an ensemble) and the stage result it implies."""
    path = ctx.artifact("training_summary.json")
    files.write_text(path, summary.model_dump_json(indent=2))
    return summary.result(str(path))
