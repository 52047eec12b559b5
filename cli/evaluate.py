"""`foresight evaluate`, `foresight diagnose` and `foresight campaign`: submitted to the server and followed
(the default), or run in-process with ``--local``.

Both build the job kind's spec (``cli.stage``). On the server, matrix, seed manifest and planner grid are
names inside a config bundle (files in the project's configs/ are named in ``builtin``; ``--bundle ID`` for
an uploaded one) and models are ids. With ``--local``, files given on the command line become one local
bundle rooted at their common folder (or the builtin bundle when they all live in the project's configs/),
and a checkpoint path becomes model id ``file:<name>``.
Exit codes: 0 passed, 2 failing gate or integrity (a result, summary written), 1 error (or a failed job).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from foresight import local
from foresight.cli import stage
from foresight.cli.client import add_connection_args
from foresight.cli.common import emit
from foresight.core.errors import ConfigError
from foresight.local import (
    ModelArgs,
    bundle_of,
    finish_local,
    local_context,
    local_workdir,
    overrides,
    planner_spec,
)


def _common(p: argparse.ArgumentParser, *, planner: bool = True) -> None:
    p.add_argument("--matrix", required=True, help="scenario matrix YAML")
    if planner:
        p.add_argument(
            "--planner",
            default="predictive",
            help="planner name (built-in, installed plugin, external; "
            "--local also module:attr), sb3:POLICY.zip (a Stable-Baselines3 policy: --local a file, server a "
            "name in --bundle) or a planner YAML ({name, config, reference_params} or a predictive config)",
        )
        p.add_argument(
            "--planner-config",
            help="the planner's config as JSON or YAML, e.g. '{\"speed\": 0.8}' or, "
            "for an external planner, '{command: NAME}'",
        )
        p.add_argument(
            "--model", help="model id, cv or static (predictive planner; --local: also a checkpoint path)"
        )
    p.add_argument(
        "--override",
        action="append",
        metavar="KEY=VALUE",
        help="run the matrix under other conditions: a scenario key (dotted, e.g. "
        "robot_config.radius=0.5; a bare simulation_config key such as ped_speed_tier=typical) "
        "set in every scenario; repeatable",
    )
    p.add_argument("--max-steps", type=int, help="horizon override for smoke runs (default: each scenario's)")
    p.add_argument("--bundle", help="server: config bundle id; --matrix/--seeds/--grid are names inside it")
    p.add_argument(
        "--out", help="--local: work folder for the artifacts (default: a new folder under <data dir>/runs)"
    )
    p.add_argument(
        "--workers",
        type=int,
        help="--local: parallel episode processes (default 1; the server's "
        "workers use FORESIGHT_STAGE_WORKERS)",
    )
    p.add_argument("--executor", choices=["local", "ray"], help=stage.EXECUTOR_HELP)
    stage.add_mode_args(p)


def register(sub: argparse._SubParsersAction) -> None:
    ev = sub.add_parser("evaluate", help="evaluate a planner on a scenario matrix")
    _common(ev)
    ev.add_argument(
        "--seeds-per-scenario",
        type=int,
        help="N seeds per scenario: its own first, extended by the next ones where it has fewer "
        "(default: the matrix's own)",
    )
    ev.add_argument("--seeds", help="seed manifest YAML: only these (scenario, seed) episodes")
    ev.add_argument("--scenarios", help="comma-separated scenario names (default: all)")
    ev.add_argument("--min-success", type=float, help="evaluation gate success floor (default 0.3)")
    ev.set_defaults(func=evaluate_cmd)

    dg = sub.add_parser("diagnose", help="hard-seed diagnostics: trace every seed of a manifest")
    _common(dg)
    dg.add_argument("--seeds", required=True, help="seed manifest YAML")
    dg.add_argument("--no-render", action="store_true", help="skip the PNG per seed")
    dg.set_defaults(func=diagnose_cmd)

    cp = sub.add_parser("campaign", help="checkpoints x planner-grid variants on a hard and a global suite")
    _common(cp, planner=False)
    cp.add_argument("--seeds", required=True, help="hard-suite seed manifest YAML (an evaluation manifest)")
    cp.add_argument("--grid", required=True, help="planner grid YAML (variants: [{name, params, config}])")
    cp.add_argument(
        "--planner", default="predictive", help="the planner the grid varies (a name or a planner YAML)"
    )
    cp.add_argument("--planner-config", help="the base config of that planner as JSON or YAML")
    cp.add_argument(
        "--checkpoints", nargs="+", default=["cv"], help="model ids, checkpoint paths, cv or static"
    )
    cp.add_argument("--baseline", help="baseline variant name for the closed-loop gate")
    cp.add_argument("--seeds-per-scenario", type=int, help="global suite: N seeds per scenario")
    cp.add_argument("--scenarios", help="global suite: comma-separated scenario names (default: all)")
    cp.set_defaults(func=campaign_cmd)

    cm = sub.add_parser(
        "compare",
        help="two evaluations: config diff and metric deltas (--local: work folders "
        "side by side per family, is a baseline better anywhere?)",
    )
    cm.add_argument(
        "runs",
        nargs="+",
        help="two evaluation ids or campaign cells CAMPAIGN_ID:RANK[:hard]; "
        "--local: evaluation work folders (with episodes.jsonl), optionally LABEL=FOLDER",
    )
    cm.add_argument("--local", action="store_true", help="compare local evaluation work folders in-process")
    cm.add_argument("--reference", help="--local: label of the planner under test (default: the first run)")
    cm.add_argument(
        "--players",
        type=Path,
        metavar="DIR",
        help="--local: write the changed episodes as side-by-side player pages (HTML) under DIR",
    )
    cm.add_argument("--json", action="store_true")
    add_connection_args(cm)
    cm.set_defaults(func=compare_cmd)


# ------------------------------------------------------------------------------ resolution helpers


def _context(args: argparse.Namespace, roots: dict[str, Path], models: ModelArgs):
    ctx = local_context(local_workdir(args.out, args.command), roots, quiet=args.json)
    ctx.resolve_model = models.resolve
    ctx.workers = max(1, int(args.workers or 1))
    return ctx


def _names(value: str | None) -> list[str] | None:
    return [s.strip() for s in value.split(",") if s.strip()] if value else None


# ------------------------------------------------------------------------------ commands


class Refs:
    """The command's inputs in the form of its mode: server (bundle names, model ids, the server's default
    predictor) or local (a local bundle of the given files, checkpoint paths, model/registry.yaml)."""

    def __init__(self, args: argparse.Namespace, files: dict[str, str | None]):
        self.args, self.local = args, args.local
        self.models = ModelArgs()
        self._client = None
        if self.local:
            if args.bundle:
                raise ConfigError(
                    "--bundle names a server bundle; --local runs take files",
                    source="command line",
                    item="--bundle",
                )
            self.bundle, paths, self.roots = bundle_of(*files.values())
            self.names = dict(zip(files, paths, strict=True))
        else:
            stage.local_only(args, out="--out", workers="--workers")
            self.bundle, self.names = stage.bundle_names(args.bundle, files)
            self.roots = {}

    @property
    def client(self):  # noqa: ANN201
        if self._client is None:
            self._client = stage.Client.from_args(self.args)
        return self._client

    def model(self, value: str | None, flag: str = "--model") -> str | None:
        return self.models.ident(value) if self.local else stage.model_id(value, flag)

    def planner(self, value: str, model: str | None) -> dict[str, Any]:
        config = getattr(self.args, "planner_config", None)
        if self.local:
            return planner_spec(value, model, self.models, config=config)
        spec = planner_spec(value, None, self.models, default=False, config=config, local=False)
        if spec.get("name") == "sb3" and self.args.bundle:
            spec["config"].setdefault("bundle", self.args.bundle)
        if model is not None:
            spec["model"] = stage.model_id(model, "--model")
        elif spec.get("model") is not None:
            spec["model"] = stage.model_id(str(spec["model"]), "--planner model")
        elif spec.get("name", "predictive") == "predictive":
            spec["model"] = stage.server_default_model(self.client)
        return spec

    def run(self, kind: str, values: dict[str, Any], text, exit_code=lambda r: 0) -> int:  # noqa: ANN001
        """Submit the ``kind`` job, or run its stage function in-process (``--local``)."""
        from foresight.core.jobs.kinds import KINDS

        if self.args.executor:
            values = {**values, "executor": self.args.executor}
        spec = local.spec(kind, values)
        if not self.local:
            return stage.submit(
                self.args,
                spec,
                text=lambda r, ref: text(r, str(ref)),
                result_model=KINDS[kind].result,
                exit_code=exit_code,
                client=self.client if self._client else None,
            )
        ctx = _context(self.args, self.roots, self.models)
        result, started = stage.run_local(
            self.args, spec, lambda: KINDS[kind].run(local.config_of(spec), ctx), ctx.workdir
        )
        pages = finish_local(kind, result, ctx.workdir)  # as a worker does: the report page, the MLflow copy
        where = f"artifacts in {ctx.workdir.resolve()}" + "".join(
            f"\nreport: {p.resolve()}" for p in pages if p.name == "report.html"
        )
        stage.emit_local(
            self.args, spec, result, lambda r: text(r, where), started=started, workdir=ctx.workdir
        )
        return exit_code(result)


def evaluate_cmd(args: argparse.Namespace) -> int:
    refs = Refs(args, {"--matrix": args.matrix, "--seeds": args.seeds})
    values: dict[str, Any] = {
        "bundle": refs.bundle,
        "matrix": refs.names["--matrix"],
        "seed_manifest": refs.names["--seeds"],
        "scenarios": _names(args.scenarios),
        "seeds_per_scenario": args.seeds_per_scenario,
        "max_steps": args.max_steps,
        "planner": refs.planner(args.planner, args.model),
        "scenario_overrides": overrides(args.override),
    }
    if args.min_success is not None:
        values["gate"] = {"min_success_rate": args.min_success}
    return refs.run("evaluate", values, _evaluation_text, lambda r: r.exit_code)


def _evaluation_text(r: Any, where: str) -> str:
    def pct(x: Any) -> str:
        return "-" if x is None else f"{100 * x:5.1f}%"

    lines = [
        f"{r.planner.variant or r.planner.name} (config {r.planner.config_hash[:12]}, model {r.planner.model_id}): "
        f"{r.episodes} episodes, success {pct(r.success_rate)}, collisions {pct(r.collision_rate)}",
        "",
        f"{'family':<36} {'n':>4} {'success':>8} {'collision':>9} {'clearance':>9}",
    ]
    for g in r.aggregates.per_family:
        clr = g.means["min_clearance"].mean
        lines.append(
            f"{g.key:<36} {g.episodes:>4} {pct(g.rates['success'].rate):>8} "
            f"{pct(g.rates['collision'].rate):>9} {'-' if clr is None else f'{clr:.2f}':>9}"
        )
    fails = ", ".join(f"{k} {v}" for k, v in r.taxonomy.items() if v) or "none"
    lines += ["", f"failures: {fails}", f"gate: {r.status}"]
    lines += [f"  {c.line()}" for c in r.gate.checks]
    if r.execution is not None:
        lines.append(f"ran on: {r.execution.describe()}")
    lines.append(where)
    return "\n".join(lines)


def diagnose_cmd(args: argparse.Namespace) -> int:
    from foresight.core.evaluation.diagnostics import report

    refs = Refs(args, {"--matrix": args.matrix, "--seeds": args.seeds})
    values = {
        "bundle": refs.bundle,
        "matrix": refs.names["--matrix"],
        "seed_manifest": refs.names["--seeds"],
        "max_steps": args.max_steps,
        "planner": refs.planner(args.planner, args.model),
        "render": not args.no_render,
        "scenario_overrides": overrides(args.override),
    }
    return refs.run("diagnose", values, lambda r, where: f"{report(r)}\n{where}")


def campaign_cmd(args: argparse.Namespace) -> int:
    from foresight.core.evaluation.campaign_text import report

    refs = Refs(args, {"--matrix": args.matrix, "--seeds": args.seeds, "--grid": args.grid})
    values: dict[str, Any] = {
        "bundle": refs.bundle,
        "matrix": refs.names["--matrix"],
        "seed_manifest": refs.names["--seeds"],
        "grid": refs.names["--grid"],
        "checkpoints": [refs.model(c, "--checkpoints") for c in args.checkpoints],
        "max_steps": args.max_steps,
        "seeds_per_scenario": args.seeds_per_scenario,
        "scenarios": _names(args.scenarios),
        "scenario_overrides": overrides(args.override),
        "planner": planner_spec(
            args.planner, None, refs.models, default=False, config=args.planner_config, local=refs.local
        ),
    }
    if args.baseline:
        values["gate"] = {"baseline_variant": args.baseline}
    return refs.run("campaign", values, lambda r, where: f"{report(r)}\n{where}", lambda r: r.exit_code)


def compare_cmd(args: argparse.Namespace) -> int:
    from foresight.core.evaluation.compare import compare, load_run, table, write_players

    if not args.local:
        if args.players:
            raise ConfigError(
                "--players writes pages from local work folders (--local); the dashboard's compare "
                "page plays a server's episodes side by side",
                source="command line",
                item="players",
            )
        from foresight.cli.report import compare_remote

        return compare_remote(args)

    runs, folders = {}, {}
    for item in args.runs:
        label, _, folder = item.rpartition("=")
        name, records = load_run(Path(folder))
        label = label or name
        if label in runs:
            raise ConfigError(
                f"two runs are labelled {label!r}; name them LABEL=FOLDER", source="command line"
            )
        runs[label], folders[label] = records, Path(folder)
    result = compare(runs, args.reference or next(iter(runs)))
    if args.players:
        result = write_players(result, folders, args.players)
    emit(result, args.json, table)
    return 0
