"""Config bundles and the model registry: start-up registration, upload validation, id resolution.

Specs name their inputs by id; :class:`Resolver` turns ids into local paths for a worker's StageContext,
verifying model checksums on the way.
"""

from __future__ import annotations

import logging
import re
import time
from pathlib import Path
from typing import Any

import yaml
from sqlalchemy import Engine, select, update
from sqlalchemy.exc import IntegrityError

from foresight.core.errors import ConfigError, CoreError, NotFoundError
from foresight.core.yamlio import load_yaml
from foresight.store import folders, job_reads, queue
from foresight.store.models import Artifact, Bundle, Dataset, Model, ModelStatus
from foresight.store.session import session_factory
from foresight.store.settings import Settings
from foresight.store.shipped import (
    DEFAULT_MODEL,
    check_model_id,
    default_model,
    read_shipped,
    shipped_checkpoint,
)

logger = logging.getLogger(__name__)

BUILTIN_BUNDLE = "builtin"
#: what a bundle may hold: configs, maps, notes, and trained policies (``.zip``, for planner ``sb3``)
BUNDLE_SUFFIXES = {".yaml", ".yml", ".svg", ".json", ".txt", ".md", ".zip"}
MAX_BUNDLE_FILES = 2000
MAX_BUNDLE_BYTES = 50 * 1024 * 1024  #: [bytes] unpacked size limit of an uploaded bundle
IDENT = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._:\-]{0,199}$")


def bundle_files(root: Path) -> list[str]:
    return sorted(
        p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file() and p.suffix in BUNDLE_SUFFIXES
    )


def matrix_files(root: Path, files: list[str]) -> list[str]:
    """The scenario matrices of a bundle: YAML files with ``scenarios`` or ``includes`` at the top level
    that no other such file includes (included files are parts of a matrix, not matrices)."""
    candidates: dict[str, Any] = {}
    for name in files:
        if not name.endswith((".yaml", ".yml")):
            continue
        try:
            data = load_yaml((root / name).read_text(), source=name)
        except (yaml.YAMLError, UnicodeDecodeError, ConfigError):
            continue
        if isinstance(data, dict) and ("includes" in data or "scenarios" in data):
            candidates[name] = data
    included = set()
    for name, data in candidates.items():
        for inc in data.get("includes") or []:
            if isinstance(inc, str):
                target = (root / name).parent.joinpath(inc).resolve()
                if root.resolve() in target.parents:
                    included.add(target.relative_to(root.resolve()).as_posix())
    return [name for name in candidates if name not in included]


def _put_bundle(
    engine: Engine, ident: str, source: str, root: Path, stored_root: str, sha: str | None
) -> None:
    files = bundle_files(root)
    with session_factory(engine, write=True).begin() as session:
        row = session.get(Bundle, ident)
        if row is None:
            row = Bundle(id=ident, created_at=time.time())
            session.add(row)
        row.source, row.root, row.files, row.scenarios, row.sha256 = (
            source,
            stored_root,
            files,
            matrix_files(root, files),
            sha,
        )


def sync_bundles(engine: Engine, settings: Settings) -> list[str]:
    """Register the project's configs/ as ``builtin`` and each extra config root under its folder name."""
    names = []
    roots = [(BUILTIN_BUNDLE, "project", settings.project_configs)]
    roots += [(d.name, "config_dir", d) for d in settings.extra_config_dirs]
    for ident, source, root in roots:
        if not root.is_dir():
            logger.warning("config root %s is missing; bundle %s not registered", root, ident)
            continue
        _put_bundle(engine, ident, source, root.resolve(), str(root.resolve()), None)
        names.append(ident)
    return names


def load_shipped_models(engine: Engine, settings: Settings) -> list[str]:
    """Register ``model/registry.yaml`` entries as read-only models (path relative to the repository)."""
    names = []
    with session_factory(engine, write=True).begin() as session:
        for entry in read_shipped(settings.model_registry):
            row = session.get(Model, entry["id"])
            if row is not None and not row.read_only:
                logger.warning("shipped model %s shadowed by a registered model of that id", entry["id"])
                continue
            if row is None:
                row = Model(id=entry["id"], created_at=time.time())
                session.add(row)
            row.checkpoint = folders.check_relative(str(entry["path"]))
            row.sha256, row.read_only = str(entry["sha256"]), True
            row.status = entry["status"]
            row.provenance = str(entry.get("provenance", ""))
            row.time_base, row.lineage = entry.get("time_base", {}), entry.get("lineage", {})
            row.training, row.metrics, row.tags = (
                entry.get("training", {}),
                entry.get("metrics", {}),
                entry.get("tags", []),
            )
            names.append(entry["id"])
    return names


def export_models(rows: list[Model]) -> str:
    """Registry entries in the schema of ``model/registry.yaml``."""
    models = [
        {
            "id": m.id,
            "path": m.checkpoint,
            "sha256": m.sha256,
            "status": m.status,
            "provenance": m.provenance,
            "time_base": m.time_base,
            "lineage": m.lineage,
            "training": m.training,
            "metrics": m.metrics,
            "tags": m.tags,
        }
        for m in rows
    ]
    return yaml.safe_dump({"models": models}, sort_keys=False)


# ------------------------------------------------------------------------------------------ resolution


class Resolver:
    """Ids → local paths, for a StageContext (``resolve_bundle``, ``resolve_dataset``, ``resolve_model``)."""

    def __init__(self, settings: Settings, engine: Engine):
        self.settings = settings
        self.engine = engine
        self.sessions = session_factory(engine)

    def run(self, ident: str) -> Path:
        """An evaluation id -> its run folder (``results.run_folder``); NotFoundError where it keeps none."""
        from foresight.store.results import run_folder

        found = run_folder(self.engine, self.settings.store_root, ident)
        if found is None:
            raise NotFoundError(f"evaluation {ident!r} keeps no run folder")
        return found.path

    def bundle_root(self, row: Bundle) -> Path:
        if row.source == "upload":
            return folders.resolve_under(self.settings.store_root, row.root)
        return Path(row.root)

    def bundle(self, ident: str) -> Path:
        with self.sessions() as session:
            row = session.get(Bundle, ident)
        if row is None:
            raise NotFoundError(f"unknown bundle id {ident!r}")
        return self.bundle_root(row)

    def dataset(self, ident: str) -> Path:
        """A dataset's file after hashing its content (a rewritten ``mixed.npz`` was trained on)."""
        with self.sessions() as session:
            row = session.get(Dataset, ident)
        if row is None:
            raise NotFoundError(f"unknown dataset id {ident!r}")
        path = folders.resolve_under(self.settings.store_root, row.path)
        if row.sha256 and path.is_file() and folders.sha256_file(path) != row.sha256:  # before any training
            raise CoreError(f"dataset {ident!r}: {Path(row.path).name} does not match its recorded sha256")
        return path

    def model_path(self, row: Model) -> Path:
        if row.read_only:
            return shipped_checkpoint(self.settings.model_registry, row.checkpoint)
        return folders.resolve_under(self.settings.store_root, row.checkpoint)

    def model_row(self, ident: str) -> Model:
        """The registry entry of a model id; ``default`` names the default model
        (:func:`~store.shipped.default_model`: status default, else a shipped entry tagged default)."""
        with self.sessions() as session:
            if (
                ident == DEFAULT_MODEL
            ):  # the rule, even over a row registered under that id before it was reserved
                row = default_model(
                    session.scalars(select(Model).order_by(Model.read_only, Model.created_at))
                )
            else:
                row = session.get(Model, ident)
        if row is None:
            raise NotFoundError(
                f"unknown model id {ident!r} (nor an installed predictor plug-in: {_plugin_hint()})"
            )
        return row

    def planner_model(self, ident: str) -> Model:
        """:meth:`model_row` of a model a planner will drive: ConfigError (422) at submission when it was trained in
        a frame the planner cannot feed: the robot's, or the focal pedestrian's (ETH/UCY-trained, forecast pedestrian
        by pedestrian, ``core.predict.focal``). Registration records the checkpoint's frame in ``lineage``."""
        row = self.model_row(ident)
        frame = row.lineage.get("frame_convention", "robot")
        if frame not in ("robot", "focal_pedestrian"):  # focal: ETH/UCY models, one pedestrian at a time
            raise ConfigError(
                f"model {row.id!r} was trained in the {frame!r} frame (robot-less data such as ETH/UCY); "
                "planners feed robot-frame or focal-pedestrian-frame features",
                item="planner.model",
            )
        return row

    def model(self, ident: str) -> Path:
        """The checkpoint of a registered model after hashing its content, every time: a cache keyed by
        (mtime, size) let a checkpoint rewritten in place with both restored pass as the registered one."""
        row = self.model_row(ident)
        if row.kind != "checkpoint":  # a predictor plug-in's or external command's folder, every file hashed
            from foresight.store.model_kinds import verified_folder

            return verified_folder(self.settings, row)
        path = self.model_path(row)
        if not path.is_file():
            raise NotFoundError(f"model {ident!r}: checkpoint {row.checkpoint} is missing")
        if folders.sha256_file(path) != row.sha256:
            raise CoreError(
                f"model {ident!r}: checkpoint {row.checkpoint} does not match its registered sha256"
            )
        return path


# ------------------------------------------------------------------------------------------ registration


def register_checkpoint(
    engine: Engine,
    settings: Settings,
    *,
    model_id: str,
    job_id: str,
    artifact: str = "model.pt",
    metadata: dict[str, Any] | None = None,
    status: str = ModelStatus.candidate.value,
    resume: bool = False,
) -> dict[str, Any]:
    """Register the checkpoint artifact ``artifact`` of succeeded job ``job_id`` as model ``model_id``.

    ``metadata`` may hold time_base (when absent, read from the checkpoint), lineage, training, metrics, tags and
    provenance. An id already taken is a :class:`~store.queue.Conflict`, unless ``resume`` and it names this
    very job's model (a retried pipeline): then that model is returned with ``resumed: True``.
    Returns ``{model_id, status, resumed}``.
    """
    meta = metadata or {}
    check_model_id(model_id)
    with session_factory(engine, write=True).begin() as session:
        existing = session.get(Model, model_id)
        if existing is not None:
            if resume and existing.job_id == job_id:
                return {"model_id": model_id, "status": existing.status, "resumed": True}
            owner = f" (job {existing.job_id})" if existing.job_id else ""
            raise queue.Conflict(f"a model with id {model_id!r} already exists{owner}")
        job = job_reads.get_job(engine, job_id)
        if job["status"] != queue.SUCCEEDED:
            raise queue.Conflict(f"job {job_id} is {job['status']}; register checkpoints of succeeded jobs")
        name = folders.check_relative(artifact)
        art = session.scalars(
            select(Artifact).where(Artifact.job_id == job_id, Artifact.name == name)
        ).first()
        if art is None:
            raise queue.JobNotFound(f"job {job_id} has no artifact {name!r}")
        checkpoint = _checkpoint(settings, art.path, art.sha256, name)
        _same_time_base(meta.get("time_base"), checkpoint["timebase"])
        session.add(
            Model(
                id=model_id,
                status=status,
                checkpoint=art.path,
                sha256=art.sha256,
                time_base=dict(checkpoint["timebase"]),
                lineage={
                    **meta.get("lineage", {}),
                    "frame_convention": checkpoint["feature_schema"]["frame_convention"],
                    "kind": "checkpoint",
                    "modes": int((checkpoint.get("model_config") or {}).get("modes", 1)),
                    "files": {name: art.sha256},
                    # recordings: the scenes of each split (a replay of a scene it learned from is refused)
                    **({"scenes": scenes} if (scenes := checkpoint["dataset"].get("scenes")) else {}),
                },
                training=meta.get("training", {}),
                metrics=meta.get("metrics", {}),
                tags=meta.get("tags", []),
                provenance=meta.get("provenance") or f"job {job_id}",
                read_only=False,
                job_id=job_id,
                created_at=time.time(),
            )
        )
        try:
            session.flush()
        except IntegrityError:
            raise queue.Conflict(f"a model with id {model_id!r} already exists") from None
    return {"model_id": model_id, "status": status, "resumed": False}


def _same_time_base(given: dict[str, Any] | None, stored: Any) -> None:
    """ConfigError (422) when a registration states a time base other than its checkpoint's (any dict was
    stored before: ``{"dt": -1}``); the registry keeps the checkpoint's."""
    from foresight.core.predict.timebase import TimeBase

    if not given:
        return
    try:
        tb = TimeBase(**given)
    except TypeError:
        raise ConfigError("time_base takes dt, history and horizon", item="time_base") from None
    except ConfigError as exc:
        raise ConfigError(exc.detail, item="time_base") from None
    TimeBase.from_dict(stored).require_same(tb, what="time_base", source="the checkpoint")


def _checkpoint(settings: Settings, path: str, sha256: str, name: str) -> dict[str, Any]:
    """The checkpoint an artifact holds: ConfigError (422) naming the artifact when it is not a checkpoint of a
    known format or its bytes no longer have the recorded sha256 (any file used to become a model)."""
    from foresight.core.predict.nn.checkpoint import read_checkpoint  # torch loads on the first registration

    try:
        return read_checkpoint(folders.resolve_under(settings.store_root, path), expect_sha256=sha256)
    except ConfigError as exc:
        raise ConfigError(exc.detail, source=f"artifact {name}", item=exc.item) from None


def _run_time_model(session: Any, model_id: str, shipped: str) -> Model:
    """A model registered at run time; JobNotFound for an unknown id, Conflict (saying ``shipped``) for a
    shipped model, whose entry lives in ``model/registry.yaml``."""
    row = session.get(Model, model_id)
    if row is None:
        raise queue.JobNotFound(f"no model with id {model_id!r}")
    if row.read_only:
        raise queue.Conflict(f"model {model_id} is shipped (model/registry.yaml); {shipped}")
    return row


def promote(engine: Engine, model_id: str, to: str = ModelStatus.promoted.value) -> dict[str, Any]:
    """Promote a model; promoting to ``default`` demotes the previous default to ``promoted``. Shipped models
    (read-only) are refused: their status lives in ``model/registry.yaml``."""
    with session_factory(engine, write=True).begin() as session:
        row = _run_time_model(session, model_id, "change its status there")
        if row.status == ModelStatus.relaxed.value:
            raise queue.Conflict(
                f"model {model_id} is relaxed: the pipeline that registered it relaxed its gates on purpose "
                "(smoke sizes), so it can never be promoted or become the default"
            )
        if to == ModelStatus.default.value:
            session.execute(
                update(Model)
                .where(Model.status == ModelStatus.default.value, Model.id != model_id)
                .values(status=ModelStatus.promoted.value)
            )
        row.status = to
    return {"model_id": model_id, "status": to}


def record_promotion(engine: Engine, model_id: str, verdict: dict[str, Any]) -> None:
    """Keep why a model was or was not promoted (the pipeline's gate verdict: failed checks with value and threshold)
    in its ``metrics["promotion"]``, which the registry's listings show."""
    with session_factory(engine, write=True).begin() as session:
        row = _run_time_model(session, model_id, "its verdict is not recorded")
        row.metrics = {**(row.metrics or {}), "promotion": verdict}


def models_using(engine: Engine, model_id: str) -> list[str]:
    """Ids of records that use a model (evaluations)."""
    from foresight.store.models import Evaluation

    with session_factory(engine)() as session:
        return list(session.scalars(select(Evaluation.id).where(Evaluation.model_id == model_id)))


# ------------------------------------------------------------------------------------------ reads


def models(
    engine: Engine, *, status: str | None = None, tag: str | None = None, run_time_only: bool = False
) -> list[Model]:
    """Registry entries, oldest first (shipped read-only entries included unless ``run_time_only``)."""
    stmt = select(Model).order_by(Model.created_at, Model.id)
    if status is not None:
        stmt = stmt.where(Model.status == status)
    if run_time_only:
        stmt = stmt.where(Model.read_only.is_(False))
    with session_factory(engine)() as session:
        return [m for m in session.scalars(stmt) if tag is None or tag in m.tags]


def model(engine: Engine, model_id: str) -> Model:
    with session_factory(engine)() as session:
        row = session.get(Model, model_id)
    if row is None:
        raise queue.JobNotFound(f"no model with id {model_id!r}")
    return row


def delete_model(engine: Engine, model_id: str) -> None:
    """Delete a run-time model; :class:`~store.queue.Conflict` for shipped or default models and models that
    records use."""
    with session_factory(engine, write=True).begin() as session:
        row = _run_time_model(session, model_id, "it is read-only")
        if row.status == ModelStatus.default.value:
            raise queue.Conflict(f"model {model_id} is the default; promote another model to default first")
        users = models_using(engine, model_id)
        if users:
            raise queue.Conflict(f"model {model_id} is used by evaluations {users[:10]}")
        session.delete(row)


def bundles(engine: Engine) -> list[Bundle]:
    """Registered config bundles by id."""
    with session_factory(engine)() as session:
        return list(session.scalars(select(Bundle).order_by(Bundle.id)))


def bundle(engine: Engine, bundle_id: str) -> Bundle | None:
    with session_factory(engine)() as session:
        return session.get(Bundle, bundle_id)


def _plugin_hint() -> str:
    """The installed predictor plug-ins, for an unknown model's error (docs/predictor_protocol.md)."""
    from foresight.core.predict import plugins

    return ", ".join(sorted(plugins.installed())) or "none installed"
