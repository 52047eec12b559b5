"""Every kind of model in one registry: a built-in checkpoint (``store.registry.register_checkpoint``), a predictor
plug-in with its artifact folder, or an operator-configured external predictor with its files.

A plug-in or external model is stored as ``models/<id>/``: ``predictor.json`` (what runs it: kind and predictor
name, ``core.predict.registered``) and ``files/`` (its artifacts, from an uploaded archive). The registry row keeps
the declaration the predictor gave when it was registered (time base, frame, mode count), the kind, and a sha256 of
every file of the folder; ``sha256`` is the digest of that list. Resolving the id hashes every file again and
refuses the model when one changed, went missing or was added, as it refuses a changed checkpoint.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.exc import IntegrityError

from foresight.core.archive import read_archive
from foresight.core.errors import ConfigError, CoreError
from foresight.core.predict.registered import DESCRIPTOR, FILES, PREDICTOR_KINDS
from foresight.store import folders, queue
from foresight.store.models import Model, ModelStatus
from foresight.store.session import session_factory
from foresight.store.settings import Settings
from foresight.store.shipped import check_model_id

KINDS = ("checkpoint", *PREDICTOR_KINDS)
MAX_MODEL_BYTES = 200 * 1024 * 1024  #: [bytes] unpacked size limit of a model's uploaded files
MAX_MODEL_FILES = 2000


def files_manifest(root: Path) -> dict[str, str]:
    """sha256 of every regular file under ``root`` by relative path (sorted)."""
    return {
        p.relative_to(root).as_posix(): folders.sha256_file(p)
        for p in sorted(root.rglob("*"))
        if p.is_file() and not p.is_symlink()
    }


def manifest_sha256(manifest: dict[str, str]) -> str:
    """One digest over every file: sha256 of the ``sha256sum`` listing (``<sha>  <path>`` lines, sorted)."""
    return hashlib.sha256("".join(f"{s}  {p}\n" for p, s in sorted(manifest.items())).encode()).hexdigest()


def check_files(model_id: str, root: Path, manifest: dict[str, str]) -> None:
    """CoreError naming the model and the first file that changed, went missing or was added since registration."""
    if not root.is_dir():
        raise CoreError(f"model {model_id!r}: its folder {root.name} is missing")
    now = files_manifest(root)
    for rel in sorted(set(manifest) | set(now)):
        what = (
            "is missing"
            if rel not in now
            else "was added"
            if rel not in manifest
            else "changed"
            if now[rel] != manifest[rel]
            else None
        )
        if what:
            raise CoreError(f"model {model_id!r}: file {rel} {what} since registration (sha256 mismatch)")


def _declaration(kind: str, predictor: str) -> dict[str, Any]:
    """The predictor's checked declaration (it is loaded, an external one started once); ConfigError (422) naming
    it when it is not of the kind given, not installed or configured, or declares something broken."""
    from foresight.core.predict import plugins
    from foresight.core.predict.external import ENV, operator_commands

    found = plugins.kind(predictor)
    if found != kind:
        expected = "an installed plug-in's name" if kind == "plugin" else f"{plugins.EXTERNAL_PREFIX}<name>"
        raise ConfigError(
            f"predictor {predictor!r} is not of kind {kind!r} (expected {expected})", item="predictor"
        )
    if kind == "external" and predictor[len(plugins.EXTERNAL_PREFIX) :] not in operator_commands():
        raise ConfigError(
            f"predictor {predictor!r} is not configured by the operator ({ENV})", item="predictor"
        )
    return plugins.load(predictor).declared.to_dict()


def register_predictor(
    engine: Engine,
    settings: Settings,
    *,
    model_id: str,
    kind: str,
    predictor: str,
    archive: bytes | None = None,
    metadata: dict[str, Any] | None = None,
    status: str = ModelStatus.candidate.value,
) -> dict[str, Any]:
    """Register predictor ``predictor`` of ``kind`` (plugin | external) with the files of ``archive`` (zip or tar;
    none: no files) as model ``model_id``; Conflict for a taken id. Returns ``{model_id, status, kind}``."""
    if kind not in KINDS[1:]:
        raise ConfigError(f"unknown kind {kind!r}; expected one of {', '.join(KINDS[1:])}", item="kind")
    meta = metadata or {}
    check_model_id(model_id)  # ids that name a rule are no model's
    with session_factory(engine)() as session:
        if session.get(Model, model_id) is not None:
            raise queue.Conflict(f"a model with id {model_id!r} already exists")
    declared = _declaration(kind, predictor)
    members = read_archive(archive, max_bytes=MAX_MODEL_BYTES, max_files=MAX_MODEL_FILES) if archive else []
    stored = f"models/{model_id}"
    dest = folders.resolve_under(settings.store_root, stored)
    if dest.exists():  # no row has this id (checked above): the files of a deleted model
        shutil.rmtree(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{model_id}.", dir=dest.parent))
    try:  # any failure leaves no staging folder and no row
        (staging / FILES).mkdir()
        for name, content in members:
            try:
                rel = folders.check_relative(name)
            except folders.UnsafePath as exc:
                raise ConfigError(str(exc), source="upload", item=name) from None
            folders.write_atomic(folders.resolve_under(staging / FILES, rel), content)
        (staging / DESCRIPTOR).write_text(json.dumps({"kind": kind, "predictor": predictor}, sort_keys=True))
        manifest = files_manifest(staging)
        try:
            staging.rename(dest)
        except OSError:  # another registration of this id stored its files first
            raise queue.Conflict(f"a model with id {model_id!r} is being registered") from None
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    lineage = {
        **meta.get("lineage", {}),
        "kind": kind,
        "predictor": predictor,
        "frame": declared["frame"],
        "modes": declared["modes"],
        "files": manifest,
    }
    try:
        with session_factory(engine, write=True).begin() as session:
            session.add(
                Model(
                    id=model_id,
                    status=status,
                    checkpoint=stored,
                    sha256=manifest_sha256(manifest),
                    time_base=declared["timebase"],
                    lineage=lineage,
                    training=meta.get("training", {}),
                    metrics=meta.get("metrics", {}),
                    tags=meta.get("tags", []),
                    provenance=meta.get("provenance") or f"{kind} {predictor}",
                    read_only=False,
                    job_id=None,
                    created_at=time.time(),
                )
            )
    except IntegrityError:
        shutil.rmtree(dest, ignore_errors=True)
        raise queue.Conflict(f"a model with id {model_id!r} already exists") from None
    return {"model_id": model_id, "status": status, "kind": kind}


def verified_folder(settings: Settings, row: Model) -> Path:
    """The folder of a registered plug-in or external model after hashing every file against its registration."""
    root = folders.resolve_under(settings.store_root, row.checkpoint)
    check_files(row.id, root, row.lineage.get("files", {}))
    return root
