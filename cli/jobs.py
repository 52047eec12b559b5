"""Client commands for jobs: `foresight submit` and `foresight jobs ls|show|edit|cancel|retry|wait|logs|delete|download`."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import yaml

from foresight.cli.client import Client, add_connection_args, dump
from foresight.core.errors import ConfigError
from foresight.core.yamlio import load_yaml
from foresight.schemas import JobEndPublic, JobPublic, JobsPublic

FINISHED = {"succeeded", "failed", "cancelled"}
SHOW_LINES = 80  #: lines of a job's pretty-printed result that `jobs show` prints


def register(sub: argparse._SubParsersAction) -> None:
    submit = sub.add_parser("submit", help="submit a job spec to the server")
    submit.add_argument("kind", help="job kind (see GET /v1/jobs/kinds)")
    submit.add_argument("-f", "--file", help="spec YAML/JSON ('-' for stdin; default: an empty spec)")
    submit.add_argument(
        "--priority", type=int, default=0, help="higher runs first among queued jobs (default 0)"
    )
    submit.add_argument("--timeout", type=float, help="[s] run time limit")
    submit.add_argument("--key", help="idempotency key: resubmitting with it returns the same job")
    add_label_args(submit)
    submit.add_argument(
        "--wait",
        action="store_true",
        help="follow the job with a progress bar until it ends "
        "(exit 0 succeeded, 2 succeeded with a failed gate or integrity verdict, 1 failed)",
    )
    submit.add_argument("--json", action="store_true")
    add_connection_args(submit)
    submit.set_defaults(func=cmd_submit)

    jobs = sub.add_parser("jobs", help="list, inspect and control jobs").add_subparsers(
        dest="action", required=True
    )
    ls = jobs.add_parser("ls", help="list jobs, newest first")
    ls.add_argument("--status", action="append", help="filter (repeatable)")
    ls.add_argument("--kind", action="append", help="filter (repeatable)")
    ls.add_argument("--tag", action="append", help="jobs with this tag (repeatable: every tag given)")
    ls.add_argument("--name", help="jobs of this exact name")
    ls.add_argument("-q", "--query", help="text in a job's name or note (case-insensitive)")
    ls.add_argument("--limit", type=int, default=20)
    ls.add_argument("--offset", type=int, default=0)
    ls.add_argument("--json", action="store_true")
    ls.set_defaults(func=cmd_ls)
    for name, func, text in (
        ("show", cmd_show, "a job's status, result and artifacts"),
        ("cancel", cmd_cancel, "cancel a queued or running job"),
        ("retry", cmd_retry, "queue a failed or cancelled job again"),
        ("delete", cmd_delete, "delete a finished job and its artifacts"),
        ("wait", cmd_wait, "wait for a job to end (exit 0 succeeded, 2 a failed gate, 1 failed)"),
        ("logs", cmd_logs, "print a job's progress and log lines (follows until it ends)"),
    ):
        p = jobs.add_parser(name, help=text)
        p.add_argument("job_id")
        p.add_argument("--json", action="store_true")
        p.set_defaults(func=func)
        if name == "wait":
            p.add_argument("--timeout", type=float, help="[s] give up after this long (exit 2)")
            p.add_argument("--quiet", action="store_true", help="no progress bar")
    edit = jobs.add_parser("edit", help="rename a job, add or remove tags, set its note")
    edit.add_argument("job_id")
    edit.add_argument("--name", help="new name ('' removes it)")
    edit.add_argument("--tag", action="append", default=[], help="add a tag (repeatable)")
    edit.add_argument("--untag", action="append", default=[], help="remove a tag (repeatable)")
    edit.add_argument("--note", help="new note ('-' reads it from stdin)")
    edit.add_argument("--json", action="store_true")
    edit.set_defaults(func=cmd_edit)
    dl = jobs.add_parser("download", help="download an artifact of a job")
    dl.add_argument("job_id")
    dl.add_argument("name", help="artifact name (as `foresight jobs show ID` lists them)")
    dl.add_argument("-o", "--output", help="file to write (default: the artifact's base name)")
    dl.set_defaults(func=cmd_download)
    for p in jobs.choices.values():
        add_connection_args(p)


def add_label_args(parser: argparse.ArgumentParser) -> None:
    """``--name``, ``--tag`` (repeatable) and ``--note`` of a submission (shown and filterable later)."""
    parser.add_argument("--name", help="what to call the job (shown in lists; `jobs ls --name`)")
    parser.add_argument("--tag", action="append", default=[], help="a tag (repeatable; `jobs ls --tag`)")
    parser.add_argument("--note", help="free text kept with the job")


def labels_body(args: argparse.Namespace) -> dict[str, Any]:
    """The label fields of a submission body from :func:`add_label_args` options."""
    body: dict[str, Any] = {"tags": args.tag} if args.tag else {}
    if args.name:
        body["name"] = args.name
    if args.note:
        body["note"] = args.note
    return body


def read_spec(path: str | None) -> dict[str, Any]:
    if path is None:
        return {}
    try:
        text = sys.stdin.read() if path == "-" else Path(path).read_text()
        data = load_yaml(text, source=path) or {}
    except OSError as exc:
        raise ConfigError(f"cannot read spec: {exc.strerror}", source=path) from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"not valid YAML: {exc}", source=path) from None
    if not isinstance(data, dict):
        raise ConfigError("a spec is a mapping of fields", source=path)
    return data


def _print(obj: Any, as_json: bool, text: str) -> None:
    print(dump(obj) if as_json else text)


GATE_FAILED_EXIT = 2  #: a finished job whose gate or integrity verdict failed (a result, not a crash)


def labels(name: str | None, tags: list[str]) -> str:
    """``  'name' #tag #tag`` of a job (or of a result, its job's labels)."""
    return "".join([f"  {name!r}" if name else "", *(f" #{t}" for t in tags)])


def _line(job: JobPublic) -> str:
    err = f"  {job.error.type}: {job.error.message[:80]}" if job.error else ""
    verdict = f"  {job.verdict.upper()}" if job.verdict and job.verdict != "passed" else ""
    return (
        f"{job.id}  {job.kind:<10} {job.status:<10} {100 * job.progress:5.1f}%  "
        f"{job.created_at.isoformat()[:19]}{verdict}{labels(job.name, job.tags)}{err}"
    )


def exit_code(job: JobPublic) -> int:
    """0 succeeded (gates passed or none), 2 succeeded with a failed gate/integrity verdict, 1 failed/cancelled."""
    if job.status != "succeeded":
        return 1
    return GATE_FAILED_EXIT if job.verdict in ("failed_gate", "failed_integrity") else 0


def cmd_submit(args: argparse.Namespace) -> int:
    client = Client.from_args(args)
    spec = read_spec(args.file)
    if "kind" in spec and spec["kind"] != args.kind:
        raise ConfigError(
            f"spec says kind {spec['kind']!r} but {args.kind!r} was given", source=args.file, item="kind"
        )
    body: dict[str, Any] = {
        "spec": {**spec, "kind": args.kind},
        "priority": args.priority,
        **labels_body(args),
    }
    if args.timeout is not None:
        body["timeout_s"] = args.timeout
    if args.key:
        body["idempotency_key"] = args.key
    job = client.fetch(JobPublic, "/v1/jobs", method="POST", json=body)
    if not args.wait:
        _print(job, args.json, job.id)
        return 0
    if not args.json:
        print(f"submitted {job.id}", file=sys.stderr)
    return follow(client, job.id, as_json=args.json, quiet=args.json)


def follow(client: Client, job_id: str, *, as_json: bool, quiet: bool, timeout: float | None = None) -> int:
    """Poll a job until it ends, with a progress bar on stderr; exit code 0 if it succeeded with no failed
    verdict, 2 if a gate or integrity check failed (or ``timeout`` passed), 1 if it failed or was cancelled."""
    job = watch(client, job_id, quiet=quiet, timeout=timeout)
    if job.status not in FINISHED:
        _print(job, as_json, f"still {job.status} after {timeout} s")
        return 2
    from foresight.cli.summary import job_summary

    _print(job, as_json, job_summary(job, client.base_url))
    return exit_code(job)


def watch(client: Client, job_id: str, *, quiet: bool, timeout: float | None = None) -> JobPublic:
    """The job once it ended (or when ``timeout`` passed), following it with a live progress bar on stderr."""
    from foresight.local import progress_bar

    deadline = time.monotonic() + timeout if timeout else None
    with progress_bar(quiet=quiet) as bar:
        task = bar.add_task(job_id[:12], total=1.0, message="")
        while True:
            job = client.job(job_id)
            bar.update(task, completed=job.progress, message=f"{job.status} {job.message[:50]}")
            if job.status in FINISHED or (deadline is not None and time.monotonic() > deadline):
                return job
            time.sleep(0.5)


def cmd_ls(args: argparse.Namespace) -> int:
    params: dict[str, Any] = {"limit": args.limit, "offset": args.offset}
    if args.status:
        params["status"] = args.status
    if args.kind:
        params["kind"] = args.kind
    for key, value in (("tag", args.tag), ("name", args.name), ("q", args.query)):
        if value:
            params[key] = value
    page = Client.from_args(args).fetch(JobsPublic, "/v1/jobs", params=params)
    lines = [_line(j) for j in page.data]
    lines.append(f"{len(page.data)} of {page.count} jobs")
    _print(page, args.json, "\n".join(lines))
    return 0


#: result fields `jobs show` leaves to --json: the resolved configs, long and read by few
CONFIG_KEYS = ("config", "taxonomy_config", "metrics_config")


def cmd_show(args: argparse.Namespace) -> int:
    """The summary first (status, verdict, headline, artifacts, page), then the result without its configs."""
    from foresight.cli.summary import job_summary

    client = Client.from_args(args)
    job = client.job(args.job_id)
    text = [job_summary(job, client.base_url)]
    if job.result is not None:
        shown = {k: v for k, v in job.result.items() if k not in CONFIG_KEYS}
        lines = json.dumps(shown, indent=2).splitlines()
        more = f"\n  ... {len(lines) - SHOW_LINES} more lines" if len(lines) > SHOW_LINES else ""
        text.append("result (configs and all: --json): " + "\n".join(lines[:SHOW_LINES]) + more)
    _print(job, args.json, "\n".join(text))
    return 0


def cmd_edit(args: argparse.Namespace) -> int:
    body: dict[str, Any] = {"add_tags": args.tag, "remove_tags": args.untag}
    if args.name is not None:
        body["name"] = args.name or None
    if args.note is not None:
        body["note"] = sys.stdin.read() if args.note == "-" else args.note
    job = Client.from_args(args).fetch(JobPublic, f"/v1/jobs/{args.job_id}", method="PATCH", json=body)
    note = f"\nnote: {job.note}" if job.note else ""
    _print(job, args.json, _line(job) + note)
    return 0


def cmd_cancel(args: argparse.Namespace) -> int:
    job = Client.from_args(args).fetch(JobPublic, f"/v1/jobs/{args.job_id}/cancel", method="POST")
    _print(job, args.json, _line(job) + ("  (cancellation requested)" if job.status == "running" else ""))
    return 0


def cmd_retry(args: argparse.Namespace) -> int:
    job = Client.from_args(args).fetch(JobPublic, f"/v1/jobs/{args.job_id}/retry", method="POST")
    _print(job, args.json, _line(job))
    return 0


def cmd_delete(args: argparse.Namespace) -> int:
    Client.from_args(args).send("DELETE", f"/v1/jobs/{args.job_id}")
    _print({"deleted": args.job_id}, args.json, f"deleted {args.job_id}")
    return 0


def cmd_wait(args: argparse.Namespace) -> int:
    return follow(
        Client.from_args(args),
        args.job_id,
        as_json=args.json,
        quiet=args.quiet or args.json,
        timeout=args.timeout,
    )


def cmd_logs(args: argparse.Namespace) -> int:
    for event, data in Client.from_args(args).events(args.job_id):
        if args.json:
            print(json.dumps({"event": event, **data.model_dump(exclude_unset=True)}), flush=True)
        elif isinstance(data, JobEndPublic):
            print(f"-- job ended: {data.status}", flush=True)
        else:
            stamp = time.strftime("%H:%M:%S", time.localtime(data.at))
            pct = f" {100 * data.progress:5.1f}%" if data.progress is not None else ""
            print(f"{stamp} {event:<8}{pct} {data.message}", flush=True)
    return 0


def cmd_download(args: argparse.Namespace) -> int:
    data = Client.from_args(args).download(f"/v1/jobs/{args.job_id}/artifacts/{args.name}")
    out = Path(args.output or Path(args.name).name)
    out.write_bytes(data)
    print(out)
    return 0
