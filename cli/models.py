"""Client commands for the registries: `foresight models ls|show|register|promote|delete|export` and
`foresight bundles ls|upload` (config bundles are the other registry)."""

from __future__ import annotations

import argparse
import io
import tarfile
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from foresight.cli.client import Client, add_connection_args, dump
from foresight.core.errors import ConfigError
from foresight.schemas import BundlePublic, BundlesPublic, ModelPublic, ModelsPublic


def register(sub: argparse._SubParsersAction) -> None:
    models = sub.add_parser("models", help="the model registry").add_subparsers(dest="action", required=True)
    ls = models.add_parser("ls", help="list registered models")
    ls.add_argument("--status", help="only models of this status (candidate, default, ...)")
    ls.add_argument("--tag", help="only models with this tag")
    ls.add_argument("--limit", type=int, help="page size (default: every model)")
    ls.add_argument("--offset", type=int, default=0)
    ls.set_defaults(func=cmd_ls)
    show = models.add_parser("show", help="one registry entry")
    show.add_argument("model_id")
    show.set_defaults(func=cmd_show)
    reg = models.add_parser(
        "register",
        help="register a checkpoint artifact of a succeeded job (--job, --artifact), or a predictor plug-in or "
        "external predictor with its files (--kind, --predictor, --files)",
    )
    reg.add_argument("model_id")
    reg.add_argument("--job", help="job id (checkpoint; a unique prefix of 8+ characters)")
    reg.add_argument("--artifact", help="artifact name in that job (checkpoint)")
    reg.add_argument(
        "--kind",
        choices=["checkpoint", "plugin", "external"],
        default="checkpoint",
        help="what is registered (default checkpoint)",
    )
    reg.add_argument("--predictor", help="plug-in name, or external:<name> (plugin, external)")
    reg.add_argument("--files", help="its artifact folder or a zip/tar of it (plugin, external; optional)")
    reg.add_argument("--tag", action="append", default=[], help="a tag for the model (repeatable)")
    reg.set_defaults(func=cmd_register)
    promote = models.add_parser("promote", help="promote a model (or make it the default)")
    promote.add_argument("model_id")
    promote.add_argument(
        "--default", action="store_true", help="make it the default model (what runs without --model)"
    )
    promote.set_defaults(func=cmd_promote)
    delete = models.add_parser("delete", help="delete a registered model")
    delete.add_argument("model_id")
    delete.set_defaults(func=cmd_delete)
    export = models.add_parser("export", help="write run-time models in the model/registry.yaml schema")
    export.add_argument("-o", "--output", help="file (default: stdout)")
    export.set_defaults(func=cmd_export)

    bundles = sub.add_parser("bundles", help="config bundles").add_subparsers(dest="action", required=True)
    bls = bundles.add_parser("ls", help="list config bundles")
    bls.set_defaults(func=cmd_bundles_ls)
    up = bundles.add_parser("upload", help="upload a folder or a zip/tar archive as a bundle")
    up.add_argument("name", help="bundle id")
    up.add_argument("path", help="folder (packed as tar.gz) or archive file")
    up.add_argument(
        "--replace",
        action="store_true",
        help="replace the files of an uploaded bundle of that id "
        "(refused while queued or running jobs use it)",
    )
    up.set_defaults(func=cmd_bundles_upload)
    bdel = bundles.add_parser(
        "delete", help="delete an uploaded bundle (refused while queued or running jobs use it)"
    )
    bdel.add_argument("name", help="bundle id")
    bdel.set_defaults(func=cmd_bundles_delete)
    for group in (models, bundles):
        for p in group.choices.values():
            add_connection_args(p)
            if "--json" not in p._option_string_actions:
                p.add_argument("--json", action="store_true")


def _out(obj: Any, as_json: bool, text: str) -> None:
    print(dump(obj) if as_json else text)


class _Why(BaseModel):
    why: str = ""


class _Promotion(BaseModel):
    """A pipeline's verdict in a model's metrics: why it was (not) promoted."""

    promotion: _Why | None = None


def _line(m: ModelPublic) -> str:
    origin = "read-only" if m.read_only else m.job_id or ""
    line = f"{m.id:<30} {m.status:<10} {m.kind:<10} {m.sha256[:12]}  {origin}"
    try:
        why = _Promotion.model_validate(m.metrics).promotion
    except ValidationError:  # metrics are free-form: a "promotion" of another shape is not a verdict
        why = None
    return line + (f"\n    {why.why}" if why is not None and why.why else "")


def cmd_ls(args: argparse.Namespace) -> int:
    params = {
        k: v
        for k, v in (
            ("status", args.status),
            ("tag", args.tag),
            ("limit", args.limit),
            ("offset", args.offset),
        )
        if v
    }
    page = Client.from_args(args).fetch(ModelsPublic, "/v1/models", params=params)
    _out(
        page,
        args.json,
        "\n".join([_line(m) for m in page.data] + [f"{len(page.data)} of {page.count} models"]),
    )
    return 0


def cmd_show(args: argparse.Namespace) -> int:
    model = Client.from_args(args).fetch(ModelPublic, f"/v1/models/{args.model_id}")
    _out(model, args.json, dump(model))
    return 0


def cmd_register(args: argparse.Namespace) -> int:
    if args.kind == "checkpoint":
        if not (args.job and args.artifact):
            raise ConfigError("a checkpoint needs --job and --artifact", source="command line", item="--job")
        body = {"id": args.model_id, "job_id": args.job, "artifact": args.artifact, "tags": args.tag}
        model = Client.from_args(args).fetch(ModelPublic, "/v1/models", method="POST", json=body)
    else:
        if not args.predictor:
            raise ConfigError(
                f"a {args.kind} model needs --predictor", source="command line", item="--predictor"
            )
        data, ctype = pack(Path(args.files)) if args.files else (b"", "application/octet-stream")
        params = {"id": args.model_id, "kind": args.kind, "predictor": args.predictor, "tag": args.tag}
        model = Client.from_args(args).fetch(
            ModelPublic,
            "/v1/models/predictors",
            method="POST",
            params=params,
            content=data,
            headers={"Content-Type": ctype},
        )
    _out(model, args.json, _line(model))
    return 0


def cmd_promote(args: argparse.Namespace) -> int:
    body = {"to": "default" if args.default else "promoted"}
    model = Client.from_args(args).fetch(
        ModelPublic, f"/v1/models/{args.model_id}/promote", method="POST", json=body
    )
    _out(model, args.json, _line(model))
    return 0


def cmd_delete(args: argparse.Namespace) -> int:
    Client.from_args(args).send("DELETE", f"/v1/models/{args.model_id}")
    _out({"deleted": args.model_id}, args.json, f"deleted {args.model_id}")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    text = Client.from_args(args).download("/v1/models/export").decode()
    if args.output:
        Path(args.output).write_text(text)
    else:
        print(text, end="")
    return 0


def cmd_bundles_ls(args: argparse.Namespace) -> int:
    page = Client.from_args(args).fetch(BundlesPublic, "/v1/bundles")
    lines = [
        f"{b.id:<30} {b.source:<10} {len(b.files):>4} files  {', '.join(b.scenarios)}" for b in page.data
    ]
    _out(page, args.json, "\n".join(lines))
    return 0


def pack(path: Path) -> tuple[bytes, str]:
    """A folder as a tar.gz (its contents at the archive root), or an archive file as is."""
    if path.is_file():
        return path.read_bytes(), "application/zip" if path.suffix == ".zip" else "application/x-tar"
    if not path.is_dir():
        raise ConfigError("no such file or folder", source=path)
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz") as tar:
        for f in sorted(p for p in path.rglob("*") if p.is_file()):
            tar.add(f, arcname=f.relative_to(path).as_posix())
    return buf.getvalue(), "application/gzip"


def cmd_bundles_upload(args: argparse.Namespace) -> int:
    data, ctype = pack(Path(args.path))
    params = {"name": args.name, **({"replace": "true"} if args.replace else {})}
    bundle = Client.from_args(args).fetch(
        BundlePublic,
        "/v1/bundles",
        method="POST",
        params=params,
        content=data,
        headers={"Content-Type": ctype},
    )
    _out(bundle, args.json, f"{bundle.id}: {len(bundle.files)} files, matrices {bundle.scenarios}")
    return 0


def cmd_bundles_delete(args: argparse.Namespace) -> int:
    Client.from_args(args).send("DELETE", f"/v1/bundles/{args.name}")
    _out({"deleted": args.name}, args.json, f"deleted bundle {args.name}")
    return 0
