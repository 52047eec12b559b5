"""The train stage as one Ray task (``executor: ray``): on a GPU node when the cluster has a GPU, else on a CPU.

The task asks for ``num_gpus=1`` when the cluster offers any GPU and ``device`` is not ``cpu`` (so Ray places it on
such a node, where ``device: auto`` resolves to cuda) and for ``threads`` CPUs otherwise; ``device: cuda`` on a
cluster without a GPU fails before anything is sent. It runs the very training function a local job runs, in a scratch folder of the node
that runs it, so nothing assumes a shared disk: the dataset (and, with a closed-loop proxy, the proxy's config
bundle) travels to it through the object store, and every file training wrote (``model.pt``, ``checkpoints/``,
the summary) comes back into the job's work folder, in the same checkpoint format. A resumed job sends its
``checkpoints/last.pt`` along, so training continues where it stopped wherever it runs.

While the task runs, the driver checks for cancellation every ``POLL_S`` and force-cancels the task when asked;
progress is reported when the task starts and when it returns (the node cannot reach the job's progress row).
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Any

from foresight.core import files
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.execution import Execution

RESUME_FILE = "checkpoints/last.pt"


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _write(root: Path, contents: dict[str, bytes]) -> None:
    for rel, blob in contents.items():
        files.write_bytes(root / rel, blob)


def _train_task(
    config: dict[str, Any], dataset: bytes, bundle: dict[str, bytes] | None, resume: dict[str, bytes]
) -> tuple[dict[str, Any], dict[str, bytes], dict[str, float]]:
    """Inside the Ray task: train in a scratch folder; (result JSON, files written, resources the task holds)."""
    import ray

    from foresight.core.training.config import TrainConfig
    from foresight.core.training.train import run_train

    scratch = Path(tempfile.mkdtemp(prefix="foresight-ray-train-"))
    try:
        (scratch / "dataset.npz").write_bytes(dataset)
        if bundle is not None:
            _write(scratch / "bundle", bundle)
        work = scratch / "work"
        work.mkdir()
        _write(work, resume)
        ctx = StageContext(
            workdir=work,
            local_files=False,
            resolve_dataset=lambda _: scratch / "dataset.npz",
            resolve_bundle=lambda _: scratch / "bundle",
        )
        cfg = TrainConfig.model_validate({**config, "executor": "local"})
        result = run_train(cfg, ctx).model_dump(mode="json")
        return result, _files(work), dict(ray.get_runtime_context().get_assigned_resources())
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def train_on_ray(config: Any, ctx: StageContext) -> Any:
    """Run ``config`` (a TrainConfig with ``executor: ray``) as one Ray task; its TrainResult, whose checkpoint and
    artifacts are in ``ctx.workdir`` as a local run leaves them."""
    import ray

    from foresight.core.errors import ConfigError
    from foresight.core.evaluation.ray_executor import POLL_S
    from foresight.core.predict.dataset import resolve_dataset_path
    from foresight.core.runtime.cluster import cluster_gpus, connect
    from foresight.core.training.config import TrainingSummary, TrainResult

    address = connect(int(ctx.workers or 1))
    gpus = 1 if config.device != "cpu" and cluster_gpus() > 0 else 0
    if config.device == "cuda" and not gpus:
        raise ConfigError(
            f"device: cuda, but the Ray cluster at {address} has no GPU (use device: auto or cpu)",
            item="device",
        )
    dataset = resolve_dataset_path(config.dataset, ctx).read_bytes()
    proxy = config.proxy if config.proxy_every > 0 else None
    bundle = None if proxy is None else _files(ctx.resolve_bundle(proxy.bundle))
    last = ctx.workdir / RESUME_FILE
    resume = {RESUME_FILE: last.read_bytes()} if config.resume and last.is_file() else {}
    options: dict[str, Any] = {"num_gpus": 1, "num_cpus": 1} if gpus else {"num_cpus": config.threads}
    task = ray.remote(max_retries=1, retry_exceptions=False)(_train_task).options(**options)
    ctx.progress(0.0, f"training as a Ray task ({'1 GPU' if gpus else f'{config.threads} CPU'}) at {address}")
    ref = task.remote(config.model_dump(mode="json"), dataset, bundle, resume)
    try:
        while not ray.wait([ref], timeout=POLL_S)[0]:
            ctx.check_cancelled()
        data, written, held = ray.get(ref)
    except BaseException:
        ray.cancel(ref, force=True)
        raise
    ctx.workdir.mkdir(parents=True, exist_ok=True)
    _write(ctx.workdir, written)
    # paths the node wrote name its scratch folder: name this work folder's files instead
    checkpoint, summary_path = (
        ctx.workdir / "model.pt",
        ctx.workdir / Path(TrainResult.model_validate(data).summary).name,
    )
    summary = TrainingSummary.model_validate_json(summary_path.read_text())
    summary = summary.model_copy(update={"checkpoint": str(checkpoint)})
    files.write_text(summary_path, summary.model_dump_json(indent=2))
    execution = Execution(
        executor="ray",
        cpus=int(held.get("CPU", 0)),
        gpus=int(held.get("GPU", 0)),
        address=address,
        device=summary.device,
    )
    ctx.progress(1.0, f"trained as a Ray task ({execution.describe()})")
    return summary.result(str(summary_path)).model_copy(update={"execution": execution})
