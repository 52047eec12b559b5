"""Optional copy of finished training, evaluation and campaign runs to an MLflow tracking server.

With ``FORESIGHT_MLFLOW_TRACKING_URI`` set, the worker (and the CLI's ``--local`` runs) log a finished run's
parameters (resolved config, config hash, code version, seeds, dt, data hash, model id), metrics (rates, ADE/FDE,
training curves per epoch) and report artifacts to that server, tagged with the Foresight job id, so a team that
already tracks its experiments in MLflow finds Foresight's runs there too.

Why in ``worker``: talking to MLflow is network I/O through a third-party client, a service-side effect of
running a job; ``core`` stays a pure library (its results are what gets exported, untouched), and the CLI,
which may import the worker, calls the same function for in-process runs. Why never fatal: the result is in
Foresight's own store already; an MLflow outage only costs the copy, reported as one warning line
(the job's log, or stderr for ``--local`` runs). The content (:func:`describe`) is built without MLflow, so what
is exported is testable on its own; ``mlflow`` is imported only here (extra ``foresight[mlflow]``).
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from pydantic import BaseModel

from foresight.core.evaluation.campaign_result import CampaignResult
from foresight.core.evaluation.evaluation_result import EvaluationResult
from foresight.core.evaluation.runner import read_records
from foresight.core.jobs.results import read_result, verdict
from foresight.core.predict.dataset import config_hash, file_sha256
from foresight.core.training.config import TrainingSummary, TrainResult

#: job kinds whose runs are exported (shards and pipeline stages export through their own kinds)
EXPORTED_KINDS = ("train", "evaluate", "campaign")
PARAM_CHARS = 500  #: longer parameter values are cut (MLflow's limit is 6000; the full config is an artifact)
#: the MLflow client's behaviour unless the operator sets these: few retries and short waits, so that an outage
#: delays a finishing job by seconds, not by the client's default minutes of back-off; no "View run" lines on
#: stdout (the CLI's --json output is there)
CLIENT_DEFAULTS = {
    "MLFLOW_HTTP_REQUEST_MAX_RETRIES": "2",
    "MLFLOW_HTTP_REQUEST_BACKOFF_FACTOR": "1",
    "MLFLOW_HTTP_REQUEST_TIMEOUT": "20",
    "MLFLOW_SUPPRESS_PRINTING_URL_TO_STDOUT": "true",
}


@dataclass(frozen=True)
class MlflowTarget:
    """Where runs go: a tracking URI and an experiment name (created on first use)."""

    tracking_uri: str
    experiment: str = "foresight"
    #: where a database-backed tracking URI (sqlite://, postgresql://, ...) keeps a new experiment's artifacts:
    #: under the data folder, not ``./mlruns`` in whatever folder the worker or the CLI runs in
    artifact_root: Path | None = None

    @property
    def database(self) -> bool:
        return urlsplit(self.tracking_uri).scheme.split("+")[0] in DATABASE_SCHEMES

    def public_uri(self) -> str:
        """The URI without credentials (``http://user:secret@host`` -> ``http://host``), for log lines."""
        return self.redact(self.tracking_uri)

    def redact(self, text: str) -> str:
        """``text`` with the URI's credentials removed (the client's error messages quote the URL)."""
        netloc = urlsplit(self.tracking_uri).netloc
        return text.replace(netloc, netloc.rpartition("@")[2]) if "@" in netloc else text


DATABASE_SCHEMES = ("sqlite", "postgresql", "mysql", "mssql")
ENV = "FORESIGHT_MLFLOW_TRACKING_URI"


def target(
    tracking_uri: str, experiment: str = "foresight", artifact_root: Path | None = None
) -> MlflowTarget | None:
    """The export target of the settings (``FORESIGHT_MLFLOW_TRACKING_URI``/``_EXPERIMENT``); None: no export.

    A ``file://`` URI (or a bare folder) is refused here, at start: MLflow 3 keeps its file store read-only, so
    every export would fail later with one warning each."""
    uri = tracking_uri.strip()
    if not uri:
        return None
    scheme = urlsplit(uri).scheme
    if scheme in ("", "file") or len(scheme) == 1:  # a path (a Windows drive letter parses as a scheme)
        from foresight.core.errors import ConfigError

        raise ConfigError(
            f"{uri!r}: MLflow 3 no longer writes to a file store; use a database, e.g. "
            "sqlite:///PATH/mlflow.db, or an MLflow server's http(s):// URL",
            source=ENV,
        )
    return MlflowTarget(uri, experiment or "foresight", artifact_root)


def settings_target(settings: Any) -> MlflowTarget | None:
    """:func:`target` of the settings, artifacts of a database-backed store under the data folder."""
    return target(
        settings.mlflow_tracking_uri, settings.mlflow_experiment, settings.data_dir / "mlflow-artifacts"
    )


@dataclass
class RunContent:
    """One MLflow run's content: what :func:`export` logs, built by :func:`describe` without MLflow."""

    name: str
    params: dict[str, str] = field(default_factory=dict)
    metrics: list[tuple[str, float, int]] = field(default_factory=list)  #: (key, value, step)
    tags: dict[str, str] = field(default_factory=dict)
    artifacts: list[tuple[Path, str | None]] = field(
        default_factory=list
    )  #: (file or folder, artifact folder)
    documents: dict[str, Any] = field(default_factory=dict)  #: artifact name -> JSON-able content

    def metric(self, key: str, value: float | int | bool | None, step: int = 0) -> None:
        if value is not None and float(value) == float(value):  # skip None and NaN
            self.metrics.append((key, float(value), step))


def flatten(prefix: str, value: Any) -> Iterator[tuple[str, str]]:
    """Nested mappings as dotted keys (``planner.safety.margin``); lists and scalars as compact JSON values."""
    if isinstance(value, dict) and value:
        for key, item in value.items():
            yield from flatten(f"{prefix}.{key}" if prefix else str(key), item)
    else:
        text = value if isinstance(value, str) else json.dumps(value, sort_keys=True, default=str)
        yield prefix, text[:PARAM_CHARS]


def describe(
    kind: str,
    result: BaseModel | dict[str, Any],
    workdir: Path,
    *,
    job_id: str | None = None,
    parent_id: str | None = None,
) -> RunContent:
    """What to log for a finished ``kind`` run whose artifacts are in ``workdir``.

    Tags: ``foresight.job_id`` (and ``foresight.parent_job_id``) for a service job, ``foresight.workdir`` for
    an in-process run; ``foresight.kind`` and ``foresight.verdict`` always.
    """
    typed = read_result(kind, result)
    data = typed.model_dump(mode="json", by_alias=True)
    content = RunContent(name=f"{kind} {job_id[:12]}" if job_id else f"{kind} (local)")
    content.tags = {
        "foresight.kind": kind,
        "foresight.verdict": verdict(kind, data) or "none",
        "foresight.mode": "service" if job_id else "local",
    }
    if job_id:
        content.tags["foresight.job_id"] = job_id
    else:
        content.tags["foresight.workdir"] = str(workdir.resolve())
    if parent_id:
        content.tags["foresight.parent_job_id"] = parent_id
    content.documents["result.json"] = data
    if isinstance(typed, TrainResult):
        _training(content, typed, workdir)
    elif isinstance(typed, EvaluationResult):
        _evaluation(content, typed, workdir)
    elif isinstance(typed, CampaignResult):
        _campaign(content, typed)
    for name in ("report.html", "report.md", "figures"):
        if (workdir / name).exists():
            content.artifacts.append((workdir / name, "figures" if name == "figures" else None))
    return content


def _in(workdir: Path, path: str) -> Path:
    return Path(path) if Path(path).is_absolute() else workdir / path


def _training(content: RunContent, result: TrainResult, workdir: Path) -> None:
    summary = TrainingSummary.model_validate_json(_in(workdir, result.summary).read_text())
    timebase = summary.dataset.get("timebase") or {}
    content.params.update(dict(flatten("config", summary.config)))
    content.params.update(
        {
            "config_hash": config_hash(summary.config),
            "code_version": summary.code_version,
            "seed": str(summary.config.get("seed")),
            "dt": str(timebase.get("dt")),
            "data_hash": str(summary.dataset.get("sha256")),
            "dataset": str(summary.dataset.get("id")),
            "selection_mode": summary.selection_mode,
            "device": str(summary.device),  # config.device: what was asked
            # a model id exists once the checkpoint is registered (foresight models register): its sha256 names it
            "checkpoint_sha256": file_sha256(_in(workdir, result.checkpoint)),
        }
    )
    content.tags["foresight.gates"] = "passed" if result.gates_passed else "failed"
    for record in summary.history:  # the training curves, one step per epoch
        for key in ("train_loss", "val_loss", "train_ade", "val_ade", "train_fde", "val_fde"):
            content.metric(key, getattr(record, key), record.epoch)
        if record.proxy is not None:
            content.metric("proxy_success", record.proxy.success, record.epoch)
            content.metric("proxy_clearance", record.proxy.clearance, record.epoch)
    for key in ("val_ade", "val_fde", "cv_val_ade", "cv_val_fde", "best_epoch"):
        content.metric(f"best.{key}", getattr(result, key))
    content.metric("gates_passed", result.gates_passed)
    content.metric("runtime_s", summary.total_runtime_s)
    content.artifacts.append((_in(workdir, result.summary), None))
    content.artifacts.append((_in(workdir, result.checkpoint), "checkpoint"))


def _evaluation(content: RunContent, result: EvaluationResult, workdir: Path) -> None:
    planner = result.planner
    records_file = workdir / result.artifacts["episodes"]
    records = read_records(records_file) if records_file.is_file() else []
    episodes = sorted({(r.scenario, r.seed) for r in records})
    content.params.update(dict(flatten("config", result.config)))
    content.params.update(dict(flatten("planner", planner.config)))
    content.params.update(
        {
            "planner_name": planner.variant or planner.name,
            "config_hash": planner.config_hash,
            "code_version": result.code_version,
            "model_id": planner.model_id,
            "checkpoint_sha256": planner.checkpoint_sha256,
            "bundle": result.bundle,
            "matrix": result.matrix,
            "seeds": result.seed_source,
            "horizon": result.horizon,
            "dt": ",".join(sorted({f"{r.provenance.dt:g}" for r in records})) or "none",
            # the episode set: equal hashes mean the same (scenario, seed) episodes, so runs compare pair by pair
            "data_hash": hashlib.sha256(json.dumps(episodes).encode()).hexdigest()[:16],
        }
    )
    content.tags["foresight.planner"] = planner.name
    content.tags["foresight.model_id"] = planner.model_id
    overall = result.aggregates.overall
    content.metric("episodes", result.episodes)
    for name, rate in overall.rates.items():
        content.metric(f"{name}_rate", rate.rate)
    for name, mean in overall.means.items():
        content.metric(name, mean.mean)
    predicted = [r.prediction for r in records if r.prediction.samples]
    if predicted:  # the in-loop forecasts' ADE/FDE, weighted by samples (planners with a predictor)
        samples = sum(p.samples for p in predicted)
        content.metric(
            "prediction_ade", sum(p.ade * p.samples for p in predicted if p.ade is not None) / samples
        )
        content.metric(
            "prediction_fde", sum(p.fde * p.samples for p in predicted if p.fde is not None) / samples
        )
    for group in result.aggregates.per_family:
        content.metric(f"family.{group.key}.success_rate", group.rates["success"].rate)
        content.metric(f"family.{group.key}.collision_rate", group.rates["collision"].rate)
    for label, count in result.taxonomy.items():
        content.metric(f"taxonomy.{label}", count)
    content.metric("gate_passed", result.gate.passed)
    content.artifacts.append((workdir / result.artifacts["summary"], None))


def _campaign(content: RunContent, result: CampaignResult) -> None:
    content.params.update(dict(flatten("config", result.config)))
    content.params.update(
        {
            "code_version": result.code_version,
            "matrix": result.matrix,
            "grid": result.grid,
            "seeds": result.seed_manifest,
            "horizon": result.horizon,
            "config_hash": config_hash(result.config),
        }
    )
    if result.best is not None:
        content.params.update({"best_variant": result.best.variant, "model_id": result.best.planner.model_id})
    for cell in result.ranked:
        for suite, summary in (("hard", cell.hard), ("global", cell.global_)):
            prefix = f"cell.{cell.variant}.{cell.checkpoint}.{suite}"
            content.metric(f"{prefix}.success_rate", summary.success.rate)
            content.metric(f"{prefix}.collision_rate", summary.collision.rate)
            content.metric(f"{prefix}.mean_min_clearance", summary.mean_min_clearance.mean)
    if result.best is not None:
        content.metric("best.hard.success_rate", result.best.hard.success.rate)
        content.metric("best.global.success_rate", result.best.global_.success.rate)


# ------------------------------------------------------------------------------------------- the MLflow side


def export(target: MlflowTarget, content: RunContent, log: Callable[[str], None]) -> str | None:
    """Log ``content`` as a new run of ``target``'s experiment; the run id, or None after one warning line
    through ``log`` (never raises: the run being exported has succeeded whatever MLflow does)."""
    run_id = None
    try:
        for key, value in CLIENT_DEFAULTS.items():
            os.environ.setdefault(key, value)
        from mlflow.entities import Metric, Param, RunTag
        from mlflow.tracking import MlflowClient

        client = MlflowClient(tracking_uri=target.tracking_uri)
        location = None
        if target.database and target.artifact_root is not None:
            location = (target.artifact_root.resolve() / target.experiment).as_uri()
        experiment_id = _experiment(client, target.experiment, location)
        job_id = content.tags.get("foresight.job_id")
        if job_id is not None:  # a job whose recording failed after its export runs again: keep one run
            done = client.search_runs(
                [experiment_id],
                f"tags.`foresight.job_id` = '{job_id}' and attributes.status = 'FINISHED'",
                max_results=1,
            )
            if done:
                log(f"MLflow: job already exported as run {done[0].info.run_id} ({target.public_uri()})")
                return str(done[0].info.run_id)
        run_id = client.create_run(experiment_id, run_name=content.name, tags=content.tags).info.run_id
        params = [Param(k, v) for k, v in content.params.items()]
        now_ms = int(time.time() * 1000)
        metrics = [Metric(k, v, now_ms, step) for k, v, step in content.metrics]
        for i in range(0, len(params), 100):  # MLflow's per-request limits: 100 params, 1000 metrics
            client.log_batch(run_id, params=params[i : i + 100])
        for i in range(0, len(metrics), 1000):
            client.log_batch(
                run_id, metrics=metrics[i : i + 1000], tags=[RunTag("mlflow.source.name", "foresight")]
            )
        for name, document in content.documents.items():
            client.log_dict(run_id, document, name)
        for path, folder in content.artifacts:
            if path.is_dir():
                client.log_artifacts(run_id, str(path), folder)
            elif path.is_file():
                client.log_artifact(run_id, str(path), folder)
        client.set_terminated(run_id, "FINISHED")
    except Exception as exc:  # noqa: BLE001 - an outage, a missing extra, a refused value: a warning, not a failure
        reason = target.redact(str(exc).splitlines()[0] if str(exc) else "")
        log(
            f"warning: MLflow export to {target.public_uri()} failed, the run is not copied there: "
            f"{type(exc).__name__}: {reason[:400]}"
        )
        if run_id is not None:
            _mark_failed(target, run_id)
        return None
    log(f"MLflow: run {run_id} in experiment {target.experiment!r} at {target.public_uri()}")
    return str(run_id)


def _experiment(client: Any, name: str, artifact_location: str | None = None) -> str:
    """The experiment's id, creating it (another worker may create it at the same moment)."""
    found = client.get_experiment_by_name(name)
    if found is not None:
        return str(found.experiment_id)
    try:
        return str(client.create_experiment(name, artifact_location=artifact_location))
    except Exception:  # noqa: BLE001 - RESOURCE_ALREADY_EXISTS from a concurrent creator
        found = client.get_experiment_by_name(name)
        if found is None:
            raise
        return str(found.experiment_id)


def _mark_failed(target: MlflowTarget, run_id: str) -> None:
    try:
        from mlflow.tracking import MlflowClient

        MlflowClient(tracking_uri=target.tracking_uri).set_terminated(run_id, "FAILED")
    except Exception:  # noqa: BLE001, S110 - the server is likely down; the run stays unfinished there
        pass


def export_run(
    target: MlflowTarget | None,
    kind: str,
    result: BaseModel | dict[str, Any],
    workdir: Path,
    log: Callable[[str], None],
    *,
    job_id: str | None = None,
    parent_id: str | None = None,
) -> str | None:
    """Export a finished run when a target is configured and the kind is exported; never raises."""
    if target is None or kind not in EXPORTED_KINDS:
        return None
    try:
        content = describe(kind, result, workdir, job_id=job_id, parent_id=parent_id)
    except Exception as exc:  # noqa: BLE001 - e.g. a summary file that went missing: the job still succeeded
        log(f"warning: MLflow export skipped, the run could not be described: {type(exc).__name__}: {exc}")
        return None
    return export(target, content, log)
