"""Store garbage: files under the store root that no database row accounts for.

Orphans are job folders of jobs that no longer exist (or never committed), uploaded-bundle folders without a
bundle row, upload staging folders (``bundles/.<id>.*``), temporaries (``*.tmp``) left by a crash or a full
disk (in the folder of a job that ended, at once: ``checkpoints/.last.pt.*.tmp`` of a killed training; elsewhere
once an hour old), and the attempt folders (``store.folders``) of succeeded jobs that a worker which lost its
lease left. Folders of jobs still queued or running are never touched, nor is any file a model or dataset row
uses.
"""

from __future__ import annotations

import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

from sqlalchemy import Engine, select

from foresight.store import folders, queue
from foresight.store.models import Bundle, Dataset, Model

TMP_AGE_S = 3600.0  #: [s] a temporary file this old belongs to no running write


@dataclass
class Garbage:
    paths: list[str] = field(default_factory=list)  #: store-relative, folders end with "/"
    bytes: int = 0


def _size(path: Path) -> int:
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


_ENDED = {queue.SUCCEEDED, queue.FAILED, queue.CANCELLED}  #: no worker writes into these jobs' folders


def _job_of(path: Path, jobs_dir: Path) -> str | None:
    """The job id whose folder holds ``path`` (``jobs/<id>/...``), else None."""
    return path.relative_to(jobs_dir).parts[0] if jobs_dir in path.parents else None


def find_garbage(engine: Engine, root: Path, *, tmp_age_s: float = TMP_AGE_S) -> tuple[Garbage, list[Path]]:
    """What :func:`collect_garbage` would remove (the report and the absolute paths)."""
    root = root.resolve()
    with engine.connect() as conn:
        status = {job: state for job, state in conn.execute(select(queue.jobs.c.id, queue.jobs.c.status))}
        jobs = set(status)
        succeeded = {job for job, state in status.items() if state == queue.SUCCEEDED}
        bundles = set(conn.execute(select(Bundle.root).where(Bundle.source == "upload")).scalars())
        used = set(conn.execute(select(Model.checkpoint)).scalars()) | set(
            conn.execute(select(Dataset.path)).scalars()
        )
    found: list[Path] = []
    jobs_dir, bundles_dir = root / "jobs", root / "bundles"
    for folder in sorted(jobs_dir.iterdir()) if jobs_dir.is_dir() else []:
        rel = folder.relative_to(root).as_posix()
        if folder.name not in jobs and not any(u.startswith(rel + "/") for u in used):
            found.append(folder)
        elif folder.name in succeeded and (folder / folders.ATTEMPTS).is_dir():
            found.append(folder / folders.ATTEMPTS)
    cutoff = time.time() - tmp_age_s
    for folder in sorted(bundles_dir.iterdir()) if bundles_dir.is_dir() else []:
        staging = folder.name.startswith(".")  # an upload being written, unless it is old
        if folder.relative_to(root).as_posix() not in bundles and not (
            staging and folder.stat().st_mtime >= cutoff
        ):
            found.append(folder)
    for tmp in sorted(root.rglob("*.tmp")):
        if not tmp.is_file() or any(p in tmp.parents for p in found):
            continue
        if tmp.stat().st_mtime < cutoff or status.get(_job_of(tmp, jobs_dir)) in _ENDED:
            found.append(tmp)
    report = Garbage(
        [p.relative_to(root).as_posix() + ("/" if p.is_dir() else "") for p in found],
        sum(_size(p) for p in found),
    )
    return report, found


def collect_garbage(
    engine: Engine, root: Path, *, dry_run: bool = False, tmp_age_s: float = TMP_AGE_S
) -> Garbage:
    """Remove the store's orphans (or only list them with ``dry_run``)."""
    report, found = find_garbage(engine, root, tmp_age_s=tmp_age_s)
    if not dry_run:
        for path in found:
            if path.is_dir():
                shutil.rmtree(path, ignore_errors=True)
            else:
                path.unlink(missing_ok=True)
    return report
