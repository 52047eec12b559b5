"""Deleting a finished job with its files: the job's whole folder, then its rows (works on a full disk)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from sqlalchemy import Engine, select

from foresight.store import folders, job_reads, queue
from foresight.store.job_rows import FINISHED_VALUES, Conflict
from foresight.store.models import Dataset, Model


def delete_job_and_files(
    engine: Engine, store_root: Path, job_id: str, on_full: Callable[[], bool] | None = None
) -> None:
    """Delete a finished job and its whole folder (partial files a failed run or a full disk left too, not only
    the recorded artifacts), keeping the files a model or dataset record uses.

    The files go first, so that a full disk has room again before the database writes; when the database still
    finds it full, ``on_full()`` frees some (the server's reserve, ``store.space``) and the rows are deleted once
    more."""
    with engine.connect() as conn:
        job = job_reads.get(conn, job_id)
        used = set(conn.execute(select(Model.checkpoint).where(Model.job_id == job_id)).scalars())
        used |= set(conn.execute(select(Dataset.path).where(Dataset.job_id == job_id)).scalars())
    if job.status not in FINISHED_VALUES:
        raise Conflict(f"job {job_id} is {job.status}; only finished jobs can be deleted (cancel it first)")
    folder = folders.resolve_under(store_root, folders.job_dir(store_root, job_id))
    for path in sorted(folder.rglob("*"), reverse=True) if folder.is_dir() else []:
        if not path.is_dir() and path.relative_to(store_root.resolve()).as_posix() not in used:
            path.unlink(missing_ok=True)
    folders.remove_empty(folder)
    try:
        queue.delete_job(engine, job_id)
    except Exception as exc:
        if not (folders.is_full_disk(exc) and on_full is not None and on_full()):
            raise
        queue.delete_job(engine, job_id)
