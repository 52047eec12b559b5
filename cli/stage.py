"""The stage commands' two modes: submit the spec to the server and follow it (the default), or run it
in-process (``--local``).

Both modes validate the same spec model, the job kind's (``core.jobs.kinds``), so a command line means the same
job either way. On the server inputs are ids (datasets, models) and bundle-relative names (matrices, seed
manifests, grids): a local file where an id is needed is refused here, before anything is sent, with a hint
to use ``--local``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from foresight.cli.client import Client, ServerUnreachable, add_connection_args, dump
from foresight.core.errors import ConfigError, CoreError
from foresight.core.runtime.refs import BUILTIN_BUNDLE
from foresight.schemas import JobPublic

#: the ``--executor`` flag of every stage command that runs episodes
EXECUTOR_HELP = (
    "where episodes run: local processes (default) or Ray tasks on the cluster at FORESIGHT_RAY_ADDRESS "
    "(else a local Ray instance)"
)

CHECKPOINT_SUFFIXES = (".pt", ".pth", ".ckpt")


def add_mode_args(p: argparse.ArgumentParser, *, json_flag: bool = True) -> None:
    """``--local``, ``--no-wait``, ``--key``, the job labels (``--name``, ``--tag``, ``--note``), the connection
    flags and (by default) ``--json``."""
    from foresight.cli.jobs import add_label_args

    p.add_argument("--local", action="store_true", help="run in-process instead of submitting to the server")
    p.add_argument("--no-wait", action="store_true", help="submit, print the job id and return (server mode)")
    p.add_argument("--key", help="idempotency key: resubmitting with it returns the same job (server mode)")
    add_label_args(p)
    add_connection_args(p)
    if json_flag:
        p.add_argument(
            "--json",
            action="store_true",
            help="print the finished job as JSON ({id, kind, status, verdict, spec, result, artifacts, ...}); "
            "--local prints the same shape (id null, artifacts as file:// URLs)",
        )


def local_only(args: argparse.Namespace, **flags: str) -> None:
    """Refuse flags that only mean something in-process (``attr="--flag"``) when submitting to the server."""
    if args.local:
        return
    for attr, flag in flags.items():
        if getattr(args, attr, None) not in (None, False):
            raise ConfigError(
                f"{flag} applies to --local runs only (a server job keeps its artifacts: "
                "`foresight jobs show ID`, `foresight jobs download ID NAME`)",
                source="command line",
                item=flag,
            )


def _local_file(value: str) -> bool:
    return Path(value).expanduser().exists()


def dataset_id(value: str | None, flag: str) -> str | None:
    """A dataset id for a server spec; a local .npz (or any existing file) is refused."""
    if value is not None and (value.endswith(".npz") or _local_file(value)):
        raise ConfigError(
            f"{value!r} is a local file; the server takes a dataset id (GET /v1/datasets, or the id "
            "of the collect/mix/import job that wrote it); run in-process with --local to use a file",
            source="command line",
            item=flag,
        )
    return value


def model_id(value: str | None, flag: str) -> str | None:
    """A model id (or ``cv``, ``static``) for a server spec; a local checkpoint file is refused."""
    if (
        value is not None
        and value not in ("cv", "static")
        and (value.endswith(CHECKPOINT_SUFFIXES) or _local_file(value))
    ):
        raise ConfigError(
            f"{value!r} is a local file; the server takes a model id (`foresight models ls`; register "
            "a job's checkpoint with `foresight models register`); run in-process with --local to use "
            "a file",
            source="command line",
            item=flag,
        )
    return value


def bundle_names(bundle: str | None, files: dict[str, str | None]) -> tuple[str, dict[str, str | None]]:
    """(bundle id, bundle-relative names) for a server spec from ``{flag: value}``.

    With ``--bundle`` the values are names inside that bundle, taken as given. Without it, each is a name in bundle
    ``builtin`` by the one rule for typed paths (``foresight.paths.bundle_name``).
    """
    if bundle is not None:
        return bundle, dict(files)
    from foresight.paths import bundle_name

    names = {flag: None if value is None else bundle_name(value, flag) for flag, value in files.items()}
    return BUILTIN_BUNDLE, names


def server_default_model(client: Client) -> str:
    """The server's default predictor id, by the server's own rule (store.shipped.default_model)."""
    from foresight.schemas import ModelsPublic
    from foresight.store.shipped import default_model

    entry = default_model(client.fetch(ModelsPublic, "/v1/models").data)
    if entry is None:
        raise ConfigError(
            "the server has no default predictor: pass --model ID or cv",
            source="command line",
            item="--model",
        )
    return entry.id


class _Exit(BaseModel):
    """The one field every stage's result has: the command's exit code (0 without one)."""

    exit_code: int = 0


class JobRef(str):
    """How to find a server job again; ``str`` is one line (id, CLI command, dashboard URL), ``.id`` the id."""

    id: str

    def __new__(cls, job_id: str, base_url: str) -> JobRef:
        obj = super().__new__(
            cls, f"job {job_id}: `foresight jobs show {job_id}`, {base_url}/ui/jobs/{job_id}"
        )
        obj.id = job_id
        return obj


def submit(
    args: argparse.Namespace,
    spec_obj: BaseModel,
    *,
    text: Callable[[Any, JobRef], str],
    result_model: type[BaseModel] | None = None,
    exit_code: Callable[[Any], int] = lambda r: 0,
    kind: str | None = None,
    client: Client | None = None,
    after: Callable[[Any, JobRef, Client], Any] | None = None,
) -> int:
    """POST the spec to ``/v1/jobs``, follow the job with a progress bar, print its result (``text(result, ref)``
    or, with ``--json``, the finished job) and return the result's exit code; a failed or cancelled job is one
    error line and exit 1. ``after(result, ref, client)`` may fetch artifacts and return an updated result."""
    from foresight.cli.jobs import watch

    client = client or Client.from_args(args)
    kind = kind or spec_obj.kind  # type: ignore[attr-defined]
    body: dict[str, Any] = {
        "spec": {**spec_obj.model_dump(mode="json", exclude_unset=True, by_alias=True), "kind": kind}
    }
    if getattr(args, "key", None):
        body["idempotency_key"] = args.key
    if hasattr(args, "tag"):
        from foresight.cli.jobs import labels_body

        body.update(labels_body(args))
    try:
        job = client.fetch(JobPublic, "/v1/jobs", method="POST", json=body)
    except ServerUnreachable as exc:
        raise CoreError(f"{exc}; start one with `foresight up`, or run in-process with --local") from None
    if args.no_wait:
        print(dump(job) if args.json else job.id)
        return 0
    if not args.json:
        print(f"{kind} job {job.id} submitted to {client.http.base_url}", file=sys.stderr)
    job = watch(client, job.id, quiet=args.json)
    if args.json:
        print(dump(job))
    if job.status != "succeeded":
        detail = f": {job.error.type}: {job.error.message}" if job.error else ""
        raise CoreError(f"{kind} job {job.id} {job.status}{detail}")
    raw: dict[str, Any] = job.result or {}
    try:
        result = result_model.model_validate(raw) if result_model is not None else raw
    except ValidationError:  # a server of another version: report the raw summary rather than fail
        if not args.json:
            print(json.dumps(raw, indent=2))
        return _Exit.model_validate(raw).exit_code
    ref = JobRef(job.id, client.base_url)
    if after is not None:
        result = after(result, ref, client)
    if not args.json:
        print(text(result, ref))
    return exit_code(result)


# ------------------------------------------------------------------------------ one --json shape in both modes


def _iso(ts: float) -> str:
    return datetime.fromtimestamp(ts, UTC).isoformat().replace("+00:00", "Z")


def _files(workdir: Path | None, files: list[Path] | None, since: float) -> list[dict[str, Any]]:
    """A local run's artifacts as the server lists a job's (name, size, sha256, a URL: here ``file://``): the files
    it wrote under its work folder (an ``--out`` folder may hold others), and ``files``."""
    from foresight.store.folders import sha256_file

    paths: list[tuple[str, Path]] = []
    if workdir is not None and workdir.is_dir():
        base = workdir.resolve()
        for path in sorted(p for p in base.rglob("*") if p.is_file() and not p.name.endswith(".tmp")):
            if path.stat().st_mtime >= since - 1.0:  # mtime granularity
                paths.append((path.relative_to(base).as_posix(), path))
    paths += [(p.name, p.resolve()) for p in files or ()]
    return [
        {"name": name, "size": path.stat().st_size, "sha256": sha256_file(path), "url": path.as_uri()}
        for name, path in paths
    ]


def local_job(
    args: argparse.Namespace,
    spec_obj: BaseModel | dict[str, Any],
    result: Any,
    *,
    started: float,
    workdir: Path | None = None,
    files: list[Path] | None = None,
    error: BaseException | None = None,
) -> dict[str, Any]:
    """The job envelope of an in-process run, so ``--json`` has one shape in both modes: the keys of the server's
    job (``GET /v1/jobs/ID``, ``foresight jobs show ID --json``) with ``id`` None, worker ``local`` and the
    artifacts (the work folder's files, or ``files``) as ``file://`` URLs."""
    from foresight.core.jobs.results import verdict

    spec = spec_obj.model_dump(mode="json") if isinstance(spec_obj, BaseModel) else dict(spec_obj)
    data = result.model_dump(mode="json") if isinstance(result, BaseModel) else result
    kind = str(spec.get("kind"))
    status = "failed" if error is not None else "succeeded"
    return {
        "id": None,
        "kind": kind,
        "status": status,
        "spec": spec,
        "priority": 0,
        "attempts": 1,
        "max_attempts": 1,
        "timeout_s": None,
        "idempotency_key": None,
        "parent_id": None,
        "name": getattr(args, "name", None),
        "tags": list(getattr(args, "tag", None) or []),
        "note": getattr(args, "note", None) or "",
        "cancel_requested": False,
        "progress": 0.0 if error is not None else 1.0,
        "message": "",
        "error": None if error is None else {"type": type(error).__name__, "message": str(error)},
        "result": data,
        "verdict": verdict(kind, data) if error is None else None,
        "worker": "local",
        "created_at": _iso(started),
        "started_at": _iso(started),
        "finished_at": _iso(time.time()),
        "artifacts": _files(workdir, files, started),
        "children": [],
    }


def run_local(
    args: argparse.Namespace,
    spec_obj: BaseModel | dict[str, Any],
    run: Callable[[], Any],
    workdir: Path | None = None,
) -> tuple[Any, float]:
    """``run()`` in-process and when it started; a failure is, with ``--json``, first printed as a failed job
    envelope (as a failed server job is), then raised."""
    started = time.time()
    try:
        return run(), started
    except Exception as exc:
        if getattr(args, "json", False):
            print(
                json.dumps(
                    local_job(args, spec_obj, None, started=started, workdir=workdir, error=exc), indent=2
                )
            )
        raise


def emit_local(
    args: argparse.Namespace,
    spec_obj: BaseModel | dict[str, Any],
    result: Any,
    text: Callable[[Any], str],
    *,
    started: float,
    workdir: Path | None = None,
    files: list[Path] | None = None,
) -> None:
    """Print an in-process run's outcome: the job envelope (:func:`local_job`) with ``--json``, else ``text``."""
    if args.json:
        print(
            json.dumps(
                local_job(args, spec_obj, result, started=started, workdir=workdir, files=files), indent=2
            )
        )
    else:
        print(text(result))
