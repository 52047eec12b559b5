"""`foresight evaluations ls` and `foresight campaigns ls`: find runs by what they ran and by their labels;
`foresight evaluations episodes ID` and `foresight campaigns episodes ID RANK`: a run's episodes, failures first, each
with the dashboard URL of its player."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from typing import Any

from foresight.cli.client import Client, add_connection_args


def register(sub: argparse._SubParsersAction) -> None:
    for group, filters, func in (
        ("evaluations", ("planner", "model_id", "matrix", "bundle", "verdict"), cmd_evaluations),
        ("campaigns", ("matrix", "grid", "model"), cmd_campaigns),
    ):  # fmt: skip
        actions = sub.add_parser(group, help=f"list stored {group}").add_subparsers(
            dest="action", required=True
        )
        ls = actions.add_parser("ls", help=f"{group}, newest first, filtered")
        for name in filters:
            ls.add_argument(
                "--" + name.replace("_", "-"),
                dest=name,
                help=f"only those whose {name.replace('_', ' ')} is this",
            )
        ls.add_argument("--name", help="their job's exact name")
        ls.add_argument("--tag", action="append", help="their job has this tag (repeatable: every tag)")
        ls.add_argument("--limit", type=int, default=20)
        ls.add_argument("--offset", type=int, default=0)
        ls.add_argument("--json", action="store_true")
        add_connection_args(ls)
        ls.set_defaults(func=func, filters=(*filters, "name", "tag"))
        eps = actions.add_parser(
            "episodes",
            help="an evaluation's episodes, failures first, with their players' URLs"
            if group == "evaluations"
            else "a campaign cell's episodes (rank 1 = best), failures first, with their players' URLs",
        )
        eps.add_argument(
            "id",
            help=f"the {group[:-1]}'s id (or its job's, a unique prefix of 8+)"
            + ("; or a local run's folder (evaluate --local --out DIR)" if group == "evaluations" else ""),
        )
        if group == "campaigns":
            eps.add_argument("rank", type=int, help="the cell's rank (1 = best)")
            eps.add_argument(
                "--suite",
                choices=("global", "hard"),
                default="global",
                help="which suite of the cell (default global)",
            )
        eps.add_argument("--failed", action="store_true", help="only the episodes that did not succeed")
        eps.add_argument(
            "--format",
            choices=("csv", "parquet", "jsonl"),
            help="export every metric of every episode as a flat table (default: the --out file's suffix)",
        )
        eps.add_argument(
            "--out", metavar="FILE", help="write the table here (.csv, .parquet or .jsonl; default stdout)"
        )
        eps.add_argument("--json", action="store_true", help="print the episode list as JSON")
        add_connection_args(eps)
        eps.set_defaults(func=cmd_episodes)


def _page(args: argparse.Namespace, path: str) -> dict[str, Any]:
    params: dict[str, Any] = {"limit": args.limit, "offset": args.offset}
    params |= {k: getattr(args, k) for k in args.filters if getattr(args, k)}
    return Client.from_args(args).get(path, params=params)


def _labels(item: dict[str, Any]) -> str:
    return "".join(
        [f"  {item['name']!r}" if item.get("name") else "", *(f" #{t}" for t in item.get("tags") or ())]
    )


def _pct(x: float | None) -> str:
    return "   -  " if x is None else f"{100 * x:5.1f}%"


def _evaluation_line(e: dict[str, Any]) -> str:
    stage, m = e["config"]["stage"], e["metrics"]
    planner = (stage.get("planner") or {}).get("name", "?")
    return (f"{e['id'][:12]}  {planner:<12} {e.get('model_id') or '-':<22} success {_pct(m['success_rate'])}  "
            f"collisions {_pct(m['collision_rate'])}  n={m['episodes']:<4} {m['status']:<16} "
            f"{stage.get('matrix', '')}{_labels(e)}")  # fmt: skip


def _campaign_line(c: dict[str, Any]) -> str:
    best = c.get("best") or {}
    glob = (c.get("best_metrics") or {}).get("global") or {}
    return (f"{c['id'][:12]}  {c['created_at'][:19]}  grid {c['config'].get('grid', '-'):<36} best "
            f"{best.get('variant', '-')}@{best.get('checkpoint', '-')} global success {_pct(glob.get('success'))}"
            f"{_labels(c)}")  # fmt: skip


def _print_page(args: argparse.Namespace, group: str, line: Callable[[dict[str, Any]], str]) -> int:
    """One page of ``GET /v1/{group}``: the JSON page with --json, else a line per item and the count."""
    page = _page(args, f"/v1/{group}")
    lines = [*map(line, page["data"]), f"{len(page['data'])} of {page['count']} {group}"]
    print(json.dumps(page, indent=2) if args.json else "\n".join(lines))
    return 0


def cmd_evaluations(args: argparse.Namespace) -> int:
    return _print_page(args, "evaluations", _evaluation_line)


def cmd_campaigns(args: argparse.Namespace) -> int:
    return _print_page(args, "campaigns", _campaign_line)


def cmd_episodes(args: argparse.Namespace) -> int:
    """``GET /v1/evaluations/ID/episodes`` or ``/v1/campaigns/ID/cells/RANK/episodes``: a line per episode."""
    if args.format or args.out:
        return _export(args)
    client = Client.from_args(args)
    if getattr(args, "rank", None) is None:
        episodes = client.get(f"/v1/evaluations/{args.id}/episodes")
    else:
        episodes = client.get(
            f"/v1/campaigns/{args.id}/cells/{args.rank}/episodes", params={"suite": args.suite}
        )
    if args.failed:
        episodes = [e for e in episodes if e["outcome"] != "success"]
    if args.json:
        print(json.dumps(episodes, indent=2))
        return 0
    base = str(client.http.base_url).rstrip("/")
    for e in episodes:
        watch = f"{base}{e['player']}" if e["player"] else "(no trace)"
        print(
            f"{e['scenario']:<36} {e['seed']:>6}  {e['outcome']:<22} {e['label'] or '':<36} {e['steps']:>5}  {watch}"
        )
    failed = sum(e["outcome"] != "success" for e in episodes)
    print(f"{len(episodes)} episodes, {failed} not successful")
    return 0


def _export(args: argparse.Namespace) -> int:
    """Every episode as a flat table: read from a local run folder, else fetched from the server's export route."""
    import sys
    from pathlib import Path

    from foresight.core.errors import ConfigError
    from foresight.core.evaluation.episode_table import encode, export_jsonl, read_jsonl, table_format

    fmt = table_format(args.format, args.out)
    if fmt == "parquet" and not args.out:
        raise ConfigError("Parquet is binary: give --out FILE.parquet", source="command line", item="--out")
    local = Path(args.id)
    if getattr(args, "rank", None) is None and (local / "episodes.jsonl").is_file():
        if args.failed:
            records = [r for r in read_jsonl(local / "episodes.jsonl") if r.get("outcome") != "success"]
            data = encode(records, fmt)
        else:
            data = export_jsonl(local / "episodes.jsonl", fmt)
    else:
        if args.failed:
            raise ConfigError("--failed lists episodes; an export holds them all (filter on the outcome column)",
                              source="command line", item="--failed")  # fmt: skip
        client = Client.from_args(args)
        if getattr(args, "rank", None) is None:
            path, params = f"/v1/evaluations/{args.id}/episodes/export", {"format": fmt}
        else:
            path = f"/v1/campaigns/{args.id}/cells/{args.rank}/episodes/export"
            params = {"format": fmt, "suite": args.suite}
        data = client.download(path, params=params)
    if args.out:
        Path(args.out).write_bytes(data)
        print(f"{args.out}: {fmt}, {len(data)} bytes", file=sys.stderr)
    else:
        sys.stdout.write(data.decode())
    return 0
