"""`foresight planners`: the planner names a spec may use (built-ins, installed plugins, external), with their
config schemas: the server's (GET /v1/planners) or, with ``--local``, this installation's."""

from __future__ import annotations

import argparse
import json

from foresight.cli.client import Client, add_connection_args


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("planners", help="list the planners and their config keys (server, or --local)")
    p.add_argument(
        "--local", action="store_true", help="this installation's planners instead of the server's"
    )
    p.add_argument("--json", action="store_true", help="print the listing as JSON (config schemas included)")
    add_connection_args(p)
    p.set_defaults(func=planners_cmd)


def planners_cmd(args: argparse.Namespace) -> int:
    if args.local:
        from foresight.core.planners.external import operator_commands
        from foresight.core.planners.registry import catalogue

        data = catalogue()
        listing = {"data": data, "count": len(data), "external_commands": sorted(operator_commands())}
    else:
        listing = Client.from_args(args).get("/v1/planners")
    if args.json:
        print(json.dumps(listing, indent=2))
        return 0
    for p in listing["data"]:
        keys = ", ".join(p["config_schema"].get("properties", {})) or "-"
        print(f"{p['name']:<14} {p['origin']:<34} config: {keys}")
    print(f"external commands: {', '.join(listing['external_commands']) or 'none'}")
    return 0
