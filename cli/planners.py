"""`foresight planners`: the planner names a spec may use (built-ins, installed plugins, external), with their
config schemas: the server's (GET /v1/planners) or, with ``--local``, this installation's.
`foresight planners check NAME`: the planner conformance check (job kind ``planner_check``), exit 2 when it fails."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from foresight.cli.client import Client, add_connection_args, dump, read
from foresight.core.errors import ConfigError
from foresight.schemas import PlannersPublic


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("planners", help="list the planners and their config keys (server, or --local)")
    p.add_argument(
        "--local", action="store_true", help="this installation's planners instead of the server's"
    )
    p.add_argument("--json", action="store_true", help="print the listing as JSON (config schemas included)")
    add_connection_args(p)
    p.set_defaults(func=planners_cmd)
    actions = p.add_subparsers(dest="action")
    c = actions.add_parser(
        "check",
        help="conformance: commands finite and within the robot's limits, deterministic, within the decision "
        "budget, with 0 and 200 pedestrians, reset leaves no state, the external protocol's error paths",
    )
    c.add_argument("name", help="planner name (built-in, plugin, external; --local also module:attr)")
    c.add_argument("--config", help="the planner's config: JSON text or a YAML/JSON file")
    c.add_argument("--model", help="predictive planner: model id, cv or static (default: the default model)")
    c.add_argument("--steps", type=int, help="decisions per episode stretch (default 40)")
    c.add_argument("--budget", type=float, help="decision budget [s] (default 0.5)")
    from foresight.cli.stage import add_mode_args

    add_mode_args(c)
    c.set_defaults(func=check_cmd)


class _Schema(BaseModel):
    """The part of a planner's config JSON schema the listing shows: its keys."""

    properties: dict[str, Any] = {}


def planners_cmd(args: argparse.Namespace) -> int:
    if args.local:
        from foresight.core.planners.external import operator_commands
        from foresight.core.planners.registry import catalogue

        data = catalogue()
        listing = PlannersPublic(data=data, count=len(data), external_commands=sorted(operator_commands()))
    else:
        listing = Client.from_args(args).fetch(PlannersPublic, "/v1/planners")
    if args.json:
        print(dump(listing))
        return 0
    for p in listing.data:
        keys = ", ".join(read(_Schema, p.config_schema, f"planner {p.name}: config_schema").properties) or "-"
        print(f"{p.name:<14} {p.origin:<34} config: {keys}")
    print(f"external commands: {', '.join(listing.external_commands) or 'none'}")
    return 0


def _config(value: str | None) -> dict[str, Any]:
    if not value:
        return {}
    path = Path(value)
    try:
        if path.is_file():
            from foresight.core.yamlio import load_yaml

            data = load_yaml(path.read_text(), source=path)
        else:
            data = json.loads(value)
    except (OSError, ValueError) as exc:
        raise ConfigError(
            f"expected JSON or a YAML file: {exc}", source="command line", item="--config"
        ) from None
    if not isinstance(data, dict):
        raise ConfigError("expected a mapping of config keys", source="command line", item="--config")
    return data


def check_text(result: Any, ref: Any = None) -> str:
    lines = [
        f"planner {result.planner}: "
        + ("CONFORMS" if result.passed else "FAILED " + ", ".join(result.failed))
    ]
    for c in result.checks:
        value = "" if c.value is None else f" value {c.value:.3g}"
        threshold = "" if c.threshold is None else f" threshold {c.threshold:.3g}"
        lines.append(f"  {'ok  ' if c.passed else 'FAIL'} {c.name:<22}{value}{threshold}  {c.detail}")
    if ref:
        lines.append(str(ref))
    return "\n".join(lines)


def check_cmd(args: argparse.Namespace) -> int:
    from foresight.cli.stage import emit_local, run_local, submit
    from foresight.core.evaluation.conformance import ConformanceResult
    from foresight.local import spec

    planner: dict[str, Any] = {"name": args.name, "config": _config(args.config)}
    if args.model:
        planner["model"] = args.model
    if args.local and ":" in args.name:
        from foresight.core.planners.registry import register

        register(args.name)
    values = {"planner": planner, "steps": args.steps, "decision_budget_s": args.budget}
    job = spec("planner_check", {k: v for k, v in values.items() if v is not None})
    if not args.local:
        return submit(
            args,
            job,
            text=check_text,
            result_model=ConformanceResult,
            exit_code=lambda r: 0 if r.passed else 2,
        )
    from foresight.core.evaluation.conformance import run_conformance
    from foresight.core.runtime.refs import BUILTIN_BUNDLE, BUILTIN_CONFIG_ROOT
    from foresight.local import ModelArgs, config_of, local_context

    ctx = local_context(None, {BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT}, quiet=True)
    ctx.resolve_model = ModelArgs().resolve
    result, started = run_local(args, job, lambda: run_conformance(config_of(job), ctx))
    emit_local(args, job, result, check_text, started=started)
    return 0 if result.passed else 2
