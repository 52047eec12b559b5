"""Replacing and deleting uploaded config bundles, refused while a queued or running job uses the bundle (its
spec names it): such a job was admitted against the files it would otherwise no longer find, or find changed.

Project and config-folder bundles come from folders on the server and are changed there, never through here.
"""

from __future__ import annotations

import shutil
from typing import Any

from sqlalchemy import Engine, delete, select

from foresight.store import folders, queue
from foresight.store.models import Bundle, Job
from foresight.store.session import session_factory, write_tx
from foresight.store.settings import Settings


def names_bundle(spec: Any, ident: str) -> bool:
    """Whether a job spec (a pipeline's nested sections too) names bundle ``ident``."""
    if isinstance(spec, dict):
        return spec.get("bundle") == ident or any(names_bundle(v, ident) for v in spec.values())
    if isinstance(spec, list):
        return any(names_bundle(v, ident) for v in spec)
    return False


def jobs_using(engine: Engine, ident: str) -> list[str]:
    """Ids of queued or running jobs whose spec names bundle ``ident``, oldest first."""
    with engine.connect() as conn:
        rows = conn.execute(
            select(Job.id, Job.spec)
            .where(Job.status.in_((queue.QUEUED, queue.RUNNING)))
            .order_by(Job.created_at)
        )
        return [job_id for job_id, spec in rows if names_bundle(spec, ident)]


def _uploaded(engine: Engine, ident: str, action: str) -> Bundle:
    with session_factory(engine)() as session:
        row = session.get(Bundle, ident)
    if row is None:
        raise queue.JobNotFound(f"no bundle with id {ident!r}")
    if row.source != "upload":
        raise queue.Conflict(
            f"bundle {ident!r} is a {row.source} bundle (a folder on the server): it cannot be {action} "
            "through the API; change its folder and restart the server"
        )
    users = jobs_using(engine, ident)
    if users:
        more = f" and {len(users) - 10} more" if len(users) > 10 else ""
        raise queue.Conflict(
            f"bundle {ident!r} is used by queued or running jobs {', '.join(users[:10])}{more}: "
            f"cancel them or wait until they finish before it is {action}"
        )
    return row


def check_replaceable(engine: Engine, ident: str) -> None:
    """404 / 409 (as :func:`replace_upload` would) before an archive is read."""
    _uploaded(engine, ident, "replaced")


def replace_upload(engine: Engine, settings: Settings, ident: str, data: bytes) -> Bundle:
    """Swap an uploaded bundle's files for a new archive's (validated first, as an upload)."""
    from foresight.store.uploads import save_upload

    _uploaded(engine, ident, "replaced")
    return save_upload(engine, settings, ident, data, replace=True)


def delete_upload(engine: Engine, settings: Settings, ident: str) -> None:
    """Delete an uploaded bundle: its row, then its folder (records that name it keep the name)."""
    row = _uploaded(engine, ident, "deleted")
    with write_tx(engine) as conn:
        conn.execute(delete(Bundle.__table__).where(Bundle.__table__.c.id == ident))
    shutil.rmtree(folders.resolve_under(settings.store_root, row.root), ignore_errors=True)
