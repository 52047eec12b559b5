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
from collections.abc import Callable
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
            help="print the result as JSON (server mode: the finished job, result included)",
        )


def local_only(args: argparse.Namespace, **flags: str) -> None:
    """Refuse flags that only mean something in-process (``attr="--flag"``) when submitting to the server."""
    if args.local:
        return
    for attr, flag in flags.items():
        if getattr(args, attr, None) not in (None, False):
            raise ConfigError(f"{flag} applies to --local runs only (a server job keeps its artifacts: "
                              "`foresight jobs show ID`, `foresight jobs download ID NAME`)", source="command line",
                              item=flag)  # fmt: skip


def _local_file(value: str) -> bool:
    return Path(value).expanduser().exists()


def dataset_id(value: str | None, flag: str) -> str | None:
    """A dataset id for a server spec; a local .npz (or any existing file) is refused."""
    if value is not None and (value.endswith(".npz") or _local_file(value)):
        raise ConfigError(f"{value!r} is a local file; the server takes a dataset id (GET /v1/datasets, or the id "
                          "of the collect/mix/import job that wrote it); run in-process with --local to use a file",
                          source="command line", item=flag)  # fmt: skip
    return value


def model_id(value: str | None, flag: str) -> str | None:
    """A model id (or ``cv``) for a server spec; a local checkpoint file is refused."""
    if value is not None and value != "cv" and (value.endswith(CHECKPOINT_SUFFIXES) or _local_file(value)):
        raise ConfigError(f"{value!r} is a local file; the server takes a model id (`foresight models ls`; register "
                          "a job's checkpoint with `foresight models register`); run in-process with --local to use "
                          "a file", source="command line", item=flag)  # fmt: skip
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


def submit(args: argparse.Namespace, spec_obj: BaseModel, *, text: Callable[[Any, JobRef], str],
           result_model: type[BaseModel] | None = None, exit_code: Callable[[Any], int] = lambda r: 0,
           kind: str | None = None, client: Client | None = None,
           after: Callable[[Any, JobRef, Client], Any] | None = None) -> int:  # fmt: skip
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
