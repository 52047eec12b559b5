"""What a stage function may use from whoever runs it (the CLI in-process, or a service worker).

Stages never see server paths in their configs: inputs are named by id and resolved here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from foresight.core.errors import CoreError, NotFoundError


class Cancelled(CoreError):
    """The job was cancelled while the stage ran."""


def _not_available(kind: str) -> Callable[[str], Path]:
    def resolve(ident: str) -> Path:
        raise NotFoundError(f"unknown {kind} id {ident!r}: no {kind} store in this context")

    return resolve


#: ``on_progress(child_id, fraction, message)`` of a child job running in its parent's slot
ChildProgress = Callable[[str, float, str], None]


class ChildJobs(Protocol):
    """The child jobs of the running job (a pipeline's stages), from whoever runs it.

    A child is a real job (its own progress, artifacts and records) submitted under an idempotency key, so a
    retried parent finds it again; :meth:`run` runs queued children in the parent's own slot and waits for
    those other workers took. A service worker backs this with its queue (``worker.children``).
    """

    parent_id: str

    def submit(self, label: str, kind: str, spec: dict[str, Any], key: str) -> tuple[dict[str, Any], bool]:
        """Queue a ``kind`` child (spec validated as the API would); (job row, created)."""
        ...

    def run(
        self,
        label: str,
        child_ids: list[str],
        on_progress: ChildProgress | None = None,
        on_wait: Callable[[dict[str, dict[str, Any]]], None] | None = None,
    ) -> tuple[dict[str, dict[str, Any]], set[str]]:
        """Drive the children until all succeeded; (final rows by id, ids run or retried by this call)."""
        ...

    def folder(self, child_id: str) -> Path:
        """A child's artifact folder."""
        ...

    def register_model(self, model_id: str, train_job: str, spec: dict[str, Any]) -> dict[str, Any]:
        """Register the ``model.pt`` of child ``train_job`` as a candidate model (the registry's one rule)."""
        ...

    def promote_model(self, model_id: str, to: str) -> dict[str, Any]:
        """Promote a model (the registry's one rule)."""
        ...

    def close(self) -> None: ...


def _no_children(role: str, workers: int | None = None) -> ChildJobs:
    raise CoreError(f"{role}: child jobs need a service worker (this context runs stages in-process)")


@dataclass
class StageContext:
    """Runtime services of one stage run.

    ``workdir`` is the folder this run writes its artifacts into (created by the caller).
    ``progress(fraction, message)`` reports progress in [0, 1]; ``log(message)`` a log line.
    ``check_cancelled()`` raises :class:`Cancelled` when the job was cancelled; long loops call it
    between units of work (episodes, batches, epochs).
    The ``resolve_*`` callables turn ids into local files (dataset file, model checkpoint,
    config-bundle root directory, named data root such as ``ethucy``, an evaluation's run folder); the service backs
    them with its
    store, registry and settings. ``local_files``: whether a stage may also take a local file path where an
    id is expected: True for library and in-process (``--local``) runs; a service worker sets False, so a job
    spec can never make the server read a path of the submitter's choosing.
    ``job_id`` is the service job this run is (None in-process); ``children(role, workers)`` opens the
    :class:`ChildJobs` of that job (call ``close()`` when done).
    """

    workdir: Path
    progress: Callable[[float, str], None] = lambda fraction, message: None
    log: Callable[[str], None] = lambda message: None
    is_cancelled: Callable[[], bool] = lambda: False
    resolve_dataset: Callable[[str], Path] = field(default_factory=lambda: _not_available("dataset"))
    resolve_model: Callable[[str], Path] = field(default_factory=lambda: _not_available("model"))
    resolve_bundle: Callable[[str], Path] = field(default_factory=lambda: _not_available("bundle"))
    resolve_data_root: Callable[[str], Path] = field(default_factory=lambda: _not_available("data root"))
    #: an evaluation id -> its run folder (episodes.jsonl, evaluation.json, traces/)
    resolve_run: Callable[[str], Path] = field(default_factory=lambda: _not_available("evaluation run"))
    local_files: bool = True
    workers: int = 1  #: processes a stage may use for parallel episodes
    job_id: str | None = None
    children: Callable[[str, int | None], ChildJobs] = _no_children

    def check_cancelled(self) -> None:
        if self.is_cancelled():
            raise Cancelled("job cancelled")

    def local_file(self, ref: str, suffixes: tuple[str, ...] = ()) -> Path | None:
        """``ref`` as an existing local file when this context accepts files (and the suffix fits), else None."""
        path = Path(ref)
        if self.local_files and path.is_file() and (not suffixes or path.suffix in suffixes):
            return path
        return None

    def artifact(self, name: str) -> Path:
        """Path for an artifact called ``name`` (a relative path) under ``workdir``, parents created."""
        path = (self.workdir / name).resolve()
        if self.workdir.resolve() not in path.parents:
            raise CoreError(f"artifact name {name!r} escapes the work directory")
        path.parent.mkdir(parents=True, exist_ok=True)
        return path
