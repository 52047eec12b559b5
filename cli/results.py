"""`foresight evaluations ls` and `foresight campaigns ls`: find runs by what they ran and by their labels."""

from __future__ import annotations

import argparse
import json
from typing import Any

from foresight.cli.client import Client, add_connection_args


def register(sub: argparse._SubParsersAction) -> None:
    for group, filters, func in (
        ("evaluations", ("planner", "model_id", "matrix", "bundle", "verdict"), cmd_evaluations),
        ("campaigns", ("matrix", "grid", "model"), cmd_campaigns),
    ):  # fmt: skip
        actions = sub.add_parser(group, help=f"list stored {group}").add_subparsers(dest="action", required=True)
        ls = actions.add_parser("ls", help=f"{group}, newest first, filtered")
        for name in filters:
            ls.add_argument("--" + name.replace("_", "-"), dest=name)
        ls.add_argument("--name", help="their job's exact name")
        ls.add_argument("--tag", action="append", help="their job has this tag (repeatable: every tag)")
        ls.add_argument("--limit", type=int, default=20)
        ls.add_argument("--offset", type=int, default=0)
        ls.add_argument("--json", action="store_true")
        add_connection_args(ls)
        ls.set_defaults(func=func, filters=(*filters, "name", "tag"))


def _page(args: argparse.Namespace, path: str) -> dict[str, Any]:
    params: dict[str, Any] = {"limit": args.limit, "offset": args.offset}
    params |= {k: getattr(args, k) for k in args.filters if getattr(args, k)}
    return Client.from_args(args).get(path, params=params)


def _labels(item: dict[str, Any]) -> str:
    return "".join([f"  {item['name']!r}" if item.get("name") else "", *(f" #{t}" for t in item.get("tags") or ())])


def _pct(x: float | None) -> str:
    return "   -  " if x is None else f"{100 * x:5.1f}%"


def cmd_evaluations(args: argparse.Namespace) -> int:
    page = _page(args, "/v1/evaluations")
    lines = []
    for e in page["data"]:
        stage, m = e["config"]["stage"], e["metrics"]
        planner = (stage.get("planner") or {}).get("name", "?")
        lines.append(f"{e['id'][:12]}  {planner:<12} {e.get('model_id') or '-':<22} success {_pct(m['success_rate'])}  "
                     f"collisions {_pct(m['collision_rate'])}  n={m['episodes']:<4} {m['status']:<16} "
                     f"{stage.get('matrix', '')}{_labels(e)}")  # fmt: skip
    lines.append(f"{len(page['data'])} of {page['count']} evaluations")
    print(json.dumps(page, indent=2) if args.json else "\n".join(lines))
    return 0


def cmd_campaigns(args: argparse.Namespace) -> int:
    page = _page(args, "/v1/campaigns")
    lines = []
    for c in page["data"]:
        best = c.get("best") or {}
        glob = (c.get("best_metrics") or {}).get("global") or {}
        lines.append(f"{c['id'][:12]}  {c['created_at'][:19]}  grid {c['config'].get('grid', '-'):<36} best "
                     f"{best.get('variant', '-')}@{best.get('checkpoint', '-')} global success {_pct(glob.get('success'))}"
                     f"{_labels(c)}")  # fmt: skip
    lines.append(f"{len(page['data'])} of {page['count']} campaigns")
    print(json.dumps(page, indent=2) if args.json else "\n".join(lines))
    return 0
