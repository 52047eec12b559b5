"""`foresight evaluations ls` and `foresight campaigns ls`: find runs by what they ran and by their labels;
`foresight evaluations episodes ID` and `foresight campaigns episodes ID RANK`: a run's episodes, failures first, each
with the dashboard URL of its player."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

from pydantic import BaseModel

from foresight.cli.client import Client, add_connection_args, dump, read
from foresight.cli.jobs import labels

# the evaluation stack loads with the first command that reads results, not with every command
if TYPE_CHECKING:
    from foresight.result_schemas import CampaignSummaryPublic, EvaluationSummaryPublic

Page = TypeVar("Page", bound=BaseModel)  #: a page of evaluations or campaigns


def register(sub: argparse._SubParsersAction) -> None:
    for group, filters, func in (
        ("evaluations", ("planner", "model_id", "matrix", "bundle", "verdict"), cmd_evaluations),
        ("campaigns", ("matrix", "grid", "model"), cmd_campaigns),
    ):
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


def _page(args: argparse.Namespace, shape: type[Page], path: str) -> Page:
    params: dict[str, Any] = {"limit": args.limit, "offset": args.offset}
    params |= {k: getattr(args, k) for k in args.filters if getattr(args, k)}
    return Client.from_args(args).fetch(shape, path, params=params)


def _pct(x: float | None) -> str:
    return "   -  " if x is None else f"{100 * x:5.1f}%"


class _Named(BaseModel):
    name: str = "?"


class _Stage(BaseModel):
    """What an evaluation's line shows of the stage config it ran (kept as given)."""

    planner: _Named | None = None
    matrix: Any = ""


def _evaluation_line(e: EvaluationSummaryPublic) -> str:
    stage, m = read(_Stage, e.config.stage, f"evaluation {e.id}: config.stage"), e.metrics
    planner = (stage.planner or _Named()).name
    return (
        f"{e.id[:12]}  {planner:<12} {e.model_id or '-':<22} success {_pct(m.success_rate)}  "
        f"collisions {_pct(m.collision_rate)}  n={m.episodes:<4} {m.status:<16} "
        f"{stage.matrix}{labels(e.name, e.tags)}"
    )


class _Grid(BaseModel):
    grid: str | None = "-"


def _campaign_line(c: CampaignSummaryPublic) -> str:
    suites = c.best_metrics or {}
    glob = suites["global"].success if "global" in suites else None
    grid = read(_Grid, c.config, f"campaign {c.id}: config").grid or "-"
    return (
        f"{c.id[:12]}  {c.created_at.isoformat()[:19]}  grid {grid:<36} best "
        f"{c.best.variant if c.best else '-'}@{c.best.checkpoint if c.best else '-'} global success "
        f"{_pct(glob)}{labels(c.name, c.tags)}"
    )


def _print_page(args: argparse.Namespace, group: str, shape: type[Page], line: Callable[[Any], str]) -> int:
    """One page of ``GET /v1/{group}``: the JSON page with --json, else a line per item and the count."""
    page = _page(args, shape, f"/v1/{group}")
    lines = [*map(line, page.data), f"{len(page.data)} of {page.count} {group}"]
    print(dump(page) if args.json else "\n".join(lines))
    return 0


def cmd_evaluations(args: argparse.Namespace) -> int:
    from foresight.result_schemas import EvaluationsPublic

    return _print_page(args, "evaluations", EvaluationsPublic, _evaluation_line)


def cmd_campaigns(args: argparse.Namespace) -> int:
    from foresight.result_schemas import CampaignsPublic

    return _print_page(args, "campaigns", CampaignsPublic, _campaign_line)


def cmd_episodes(args: argparse.Namespace) -> int:
    """``GET /v1/evaluations/ID/episodes`` or ``/v1/campaigns/ID/cells/RANK/episodes``: a line per episode."""
    if args.format or args.out:
        return _export(args)
    from foresight.result_schemas import EpisodePublic

    client = Client.from_args(args)
    if getattr(args, "rank", None) is None:
        episodes = client.fetch(list[EpisodePublic], f"/v1/evaluations/{args.id}/episodes")
    else:
        episodes = client.fetch(
            list[EpisodePublic],
            f"/v1/campaigns/{args.id}/cells/{args.rank}/episodes",
            params={"suite": args.suite},
        )
    if args.failed:
        episodes = [e for e in episodes if e.outcome != "success"]
    if args.json:
        print(dump(episodes))
        return 0
    for e in episodes:
        watch = f"{client.base_url}{e.player}" if e.player else "(no trace)"
        print(f"{e.scenario:<36} {e.seed:>6}  {e.outcome:<22} {e.label or '':<36} {e.steps:>5}  {watch}")
    failed = sum(e.outcome != "success" for e in episodes)
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
            raise ConfigError(
                "--failed lists episodes; an export holds them all (filter on the outcome column)",
                source="command line",
                item="--failed",
            )
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
