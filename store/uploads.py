"""Uploaded config bundles: an archive is read within the bundle limits, every member's name and every YAML
path inside it checked, its matrices loaded, and only then stored under ``bundles/<id>`` in one rename."""

from __future__ import annotations

import hashlib
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any

import yaml
from sqlalchemy import Engine

from foresight.core.archive import read_archive
from foresight.core.errors import ConfigError, CoreError
from foresight.core.limits import MAX_NAME_BYTES
from foresight.core.yamlio import load_yaml
from foresight.store import folders
from foresight.store.models import Bundle
from foresight.store.registry import (
    BUILTIN_BUNDLE,
    BUNDLE_SUFFIXES,
    IDENT,
    MAX_BUNDLE_BYTES,
    MAX_BUNDLE_FILES,
    _put_bundle,
    bundle_files,
    matrix_files,
)
from foresight.store.session import session_factory
from foresight.store.settings import Settings


def _members(data: bytes) -> list[tuple[str, bytes]]:
    """(name, content) of the regular files in a zip or tar archive, read within the bundle limits."""
    return read_archive(data, max_bytes=MAX_BUNDLE_BYTES, max_files=MAX_BUNDLE_FILES)


def _check_yaml_refs(value: Any, file: str, root: Path, where: str = "") -> None:
    """Path-like strings in a bundle YAML must stay inside the bundle (relative, resolved under root)."""
    if isinstance(value, dict):
        for k, v in value.items():
            _check_yaml_refs(v, file, root, f"{where}.{k}" if where else str(k))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _check_yaml_refs(v, file, root, f"{where}[{i}]")
    elif isinstance(value, str) and (
        "/" in value or "\\" in value or value.endswith((".yaml", ".yml", ".svg"))
    ):
        if value.startswith(("/", "\\", "~")) or re.match(r"^[A-Za-z]:[\\/]", value):
            raise ConfigError(f"absolute path {value!r} not allowed", source=file, item=where)
        target = (root / file).parent.joinpath(value).resolve()
        if target != root and root not in target.parents:
            raise ConfigError(f"path {value!r} leaves the bundle", source=file, item=where)


def _member_paths(members: list[tuple[str, bytes]]) -> list[tuple[str, bytes]]:
    """(bundle-relative path, content) of an archive's members; ConfigError naming the member for an unsafe or
    overlong name, a file type not kept, or a name that is also another member's folder (``maps/c.yaml`` and
    ``maps/c.yaml/d.yaml``: writing the second failed, and the failure read as "bundle already exists")."""
    out = []
    for name, content in members:
        try:
            rel = folders.check_relative(name)
        except folders.UnsafePath as exc:
            raise ConfigError(str(exc), source="upload", item=name) from None
        if any(len(part.encode("utf-8", "surrogatepass")) > MAX_NAME_BYTES for part in Path(rel).parts):
            raise ConfigError(f"a name over {MAX_NAME_BYTES} bytes", source="upload", item=rel[:80])
        if Path(rel).suffix not in BUNDLE_SUFFIXES:
            raise ConfigError(
                f"file type not allowed (allowed: {sorted(BUNDLE_SUFFIXES)})", source="upload", item=rel
            )
        out.append((rel, content))
    files = {rel for rel, _ in out}
    for rel in files:
        clash = next((str(p) for p in Path(rel).parents if str(p) in files), None)
        if clash is not None:
            raise ConfigError(
                f"{clash!r} is both a file and the folder of {rel!r}", source="upload", item=rel
            )
    return out


def save_upload(
    engine: Engine, settings: Settings, ident: str, data: bytes, *, replace: bool = False
) -> Bundle:
    """Validate an uploaded zip/tar bundle and store it under ``bundles/<id>``; ConfigError when invalid.
    ``replace``: swap out the files of an uploaded bundle of that id (``store.bundles.replace_upload``)."""
    from foresight.core.scenarios.loader import load_matrix

    if not IDENT.match(ident) or ident == BUILTIN_BUNDLE:
        raise ConfigError(
            "bundle id must be letters, digits, '.', '_', '-', ':' (not 'builtin')", item="name"
        )
    members = _members(data)
    if not members:
        raise ConfigError("the archive holds no files", source="upload")
    with tempfile.TemporaryDirectory(prefix="bundle-") as tmp:
        root = Path(tmp).resolve()
        for rel, content in _member_paths(members):
            folders.write_atomic(folders.resolve_under(root, rel), content)
        files = bundle_files(root)
        for rel in files:
            if rel.endswith((".yaml", ".yml")):
                try:
                    _check_yaml_refs(load_yaml((root / rel).read_text(), source=rel), rel, root)
                except (yaml.YAMLError, UnicodeDecodeError) as exc:
                    raise ConfigError(f"not valid YAML: {exc}", source=rel) from None
        matrices = matrix_files(root, files)
        if not matrices and not any(rel.endswith(".zip") for rel in files):
            raise ConfigError(
                "no scenario matrix (a YAML file with 'scenarios' or 'includes') and no policy (.zip)",
                source="upload",
            )
        for rel in matrices:
            try:
                load_matrix(root / rel)
            except CoreError as exc:  # named inside the bundle: the staging folder is the server's
                raise ConfigError(
                    str(exc).replace(f"{root}/", "").replace(str(root), "."), source=rel
                ) from None
        stored = f"bundles/{ident}"
        dest = folders.resolve_under(settings.store_root, stored)
        if dest.exists() and not replace:
            raise FileExistsError(ident)
        dest.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{ident}.", dir=dest.parent))
        old = None
        try:  # a full disk (or any failure) leaves no staging folder behind
            for rel in files:
                folders.write_atomic(staging / rel, (root / rel).read_bytes())
            if dest.exists():  # replace: the old files step aside (a staging-named folder gc knows), then go
                old = Path(tempfile.mkdtemp(prefix=f".{ident}.", dir=dest.parent)) / "old"
                dest.rename(old)
            staging.rename(dest)
        except BaseException:
            if old is not None and old.exists() and not dest.exists():
                old.rename(dest)
            shutil.rmtree(staging, ignore_errors=True)
            raise
        finally:
            if old is not None:
                shutil.rmtree(old.parent, ignore_errors=True)
    _put_bundle(engine, ident, "upload", dest, stored, hashlib.sha256(data).hexdigest())
    with session_factory(engine)() as session:
        return session.get(Bundle, ident)
