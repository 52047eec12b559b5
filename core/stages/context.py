"""What a stage function may use from whoever runs it (the CLI in-process, or a service worker).

Stages never see server paths in their configs: inputs are named by id and resolved here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from foresight.core.errors import CoreError, NotFoundError


class Cancelled(CoreError):
    """The job was cancelled while the stage ran."""


def _not_available(kind: str) -> Callable[[str], Path]:
    def resolve(ident: str) -> Path:
        raise NotFoundError(f"unknown {kind} id {ident!r}: no {kind} store in this context")

    return resolve


@dataclass
class StageContext:
    """Runtime services of one stage run.

    ``workdir`` is the folder this run writes its artifacts into (created by the caller).
    ``progress(fraction, message)`` reports progress in [0, 1]; ``log(message)`` a log line.
    ``check_cancelled()`` raises :class:`Cancelled` when the job was cancelled; long loops call it
    between units of work (episodes, batches, epochs).
    The ``resolve_*`` callables turn ids into local files (dataset file, model checkpoint,
    config-bundle root directory, named data root such as ``ethucy``); the service backs them with its
    store, registry and settings. ``local_files``: whether a stage may also take a local file path where an
    id is expected: True for library and in-process (``--local``) runs; a service worker sets False, so a job
    spec can never make the server read a path of the submitter's choosing.
    """

    workdir: Path
    progress: Callable[[float, str], None] = lambda fraction, message: None
    log: Callable[[str], None] = lambda message: None
    is_cancelled: Callable[[], bool] = lambda: False
    resolve_dataset: Callable[[str], Path] = field(default_factory=lambda: _not_available("dataset"))
    resolve_model: Callable[[str], Path] = field(default_factory=lambda: _not_available("model"))
    resolve_bundle: Callable[[str], Path] = field(default_factory=lambda: _not_available("bundle"))
    resolve_data_root: Callable[[str], Path] = field(default_factory=lambda: _not_available("data root"))
    local_files: bool = True
    workers: int = 1  #: processes a stage may use for parallel episodes

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
