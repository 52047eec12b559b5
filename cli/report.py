"""Client commands that read results back: `foresight report JOB_ID` and `foresight compare A B`.

``report`` prints the Markdown report a worker wrote beside a finished job's artifacts (``--out DIR`` also
fetches the HTML page and its figures); ``compare`` asks the server for the runbook's A/B comparison of two
evaluations (``GET /v1/compare``). ``compare --local`` compares evaluation work folders in-process.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from foresight.cli.client import Client, add_connection_args, dump
from foresight.core.errors import ConfigError
from foresight.core.evaluation.stats import ALPHA, MIN_PAIRS

if TYPE_CHECKING:  # the evaluation stack loads with `compare`, not with every command
    from foresight.core.evaluation.delta import Delta, Estimate
    from foresight.result_schemas import ComparisonPublic, Sides
    from foresight.schemas import JobPublic

REPORT_MD, REPORT_HTML = "report.md", "report.html"


def register(sub: argparse._SubParsersAction) -> None:
    rp = sub.add_parser(
        "report", help="a finished job's report (Markdown; --out DIR: HTML page with figures)"
    )
    rp.add_argument("job_id")
    rp.add_argument("--out", help="folder to download the report page, its figures and report.md into")
    rp.add_argument("--json", action="store_true", help="the job, its result and the report's artifact URLs")
    add_connection_args(rp)
    rp.set_defaults(func=report_cmd)


def _download(client: Client, job_id: str, name: str) -> bytes:
    return client.download(f"/v1/jobs/{job_id}/artifacts/{name}")


def report_files(job: JobPublic) -> list[str]:
    """Artifact names that make up the job's report: the two pages and the figures they sit beside."""
    from foresight.core.reports.common import FIGURES  # matplotlib: not at every command's start-up

    names = [a.name for a in job.artifacts or []]
    if REPORT_MD not in names and REPORT_HTML not in names:
        return []
    return [n for n in names if n in (REPORT_MD, REPORT_HTML) or n.startswith(f"{FIGURES}/")]


def report_cmd(args: argparse.Namespace) -> int:
    client = Client.from_args(args)
    job = client.job(args.job_id)
    files = report_files(job)
    if not files:
        raise ConfigError(
            f"job {args.job_id} ({job.kind}, {job.status}) has no report: reports are written "
            "when a collect, train, evaluate, diagnose, campaign or pipeline job succeeds",
            item=args.job_id,
        )
    written: list[str] = []
    if args.out:
        out = Path(args.out)
        for name in files:
            dest = (out / name).resolve()
            if out.resolve() not in dest.parents:
                raise ConfigError(f"artifact name {name!r} escapes {out}", item=name)
            dest.parent.mkdir(parents=True, exist_ok=True)
            dest.write_bytes(_download(client, args.job_id, name))
            written.append(str(dest))
    if args.json:
        urls = {a.name: a.url for a in job.artifacts or [] if a.name in files}
        print(
            json.dumps(
                {
                    "job": job.id,
                    "kind": job.kind,
                    "status": job.status,
                    "result": job.result,
                    "report": urls,
                    "written": written,
                },
                indent=2,
            )
        )
        return 0
    if REPORT_MD in files:
        print(_download(client, args.job_id, REPORT_MD).decode())
    if written:
        page = next((w for w in written if w.endswith(REPORT_HTML)), written[0])
        print(f"report page: {page}")
    return 0


def compare_remote(args: argparse.Namespace) -> int:
    """Two evaluation ids or campaign cells (``CAMPAIGN_ID:RANK[:hard]``): the resolved-config diff key by key and
    the headline metric deltas (B - A) with intervals."""
    if len(args.runs) != 2:
        raise ConfigError(
            f"the server compares two results (got {len(args.runs)} ids); folders of local "
            "evaluation runs compare with --local",
            source="command line",
            item="runs",
        )
    for value in args.runs:
        if Path(value.rpartition("=")[2]).expanduser().exists():
            raise ConfigError(
                f"{value!r} is a local folder; the server compares evaluation ids (GET /v1/evaluations"
                " via `foresight jobs ls --kind evaluate`); compare folders with --local",
                source="command line",
                item="runs",
            )
    a, b = args.runs
    from foresight.result_schemas import ComparisonPublic

    client = Client.from_args(args)
    result = client.fetch(ComparisonPublic, "/v1/compare", params={"a": a, "b": b})
    if args.json:
        print(dump(result))
        return 0
    print(compare_text(result, client.base_url))
    return 0


def compare_text(body: ComparisonPublic | dict[str, Any], base_url: str = "") -> str:
    """The text of a ``GET /v1/compare`` body; each changed episode with its side-by-side player's URL (on
    ``base_url``) where both results kept its trace."""
    from foresight.result_schemas import ComparisonPublic

    result = ComparisonPublic.model_validate(body)
    lines = [f"A = {result.a}    B = {result.b}", ""]
    if (
        result.differs is not None
    ):  # what was run differently leads: planner, model, matrix, episodes, horizon
        lines += (
            ["differs:"]
            + (
                [f"  {key}: {_short(v.a)} -> {_short(v.b)}" for key, v in result.differs.items()]
                or ["  nothing in planner, model, matrix, episodes, horizon"]
            )
            + [""]
        )
    if result.sources is not None:
        lines.insert(1, f"A: {result.sources.a}    B: {result.sources.b}")
    lines += [f"{'metric':<22}{'A':>24}{'B':>24}{'B - A [95 % interval]':>34}  method"]
    for name, m in result.metrics.items():
        interval = f" [{_num(m.low)}, {_num(m.high)}]" + (" *" if m.significant else "")
        lines.append(
            f"{name:<22}{_value(m.a):>24}{_value(m.b):>24}{_num(m.delta) + interval:>34}  {_method(m)}"
        )
    lines.append(
        f"* significant: paired p < {ALPHA} (McNemar exact / Wilcoxon signed-rank), unpaired the interval "
        f"excludes 0; never with fewer than {MIN_PAIRS} episodes"
    )
    diff = config_keys(result.config_diff)
    lines += ["", f"config (keys that differ: {len(diff)}):"]
    shown = list(diff.items())[:CONFIG_LINES]
    lines += [f"  {key}: {_short(v.a)} -> {_short(v.b)}" for key, v in shown] or ["  identical"]
    if len(diff) > CONFIG_LINES:
        lines.append(f"  ... {len(diff) - CONFIG_LINES} more (--json for all)")
    if result.changed_episodes is not None:  # paired evaluations: the discordant episodes by name
        from foresight.core.evaluation.compare import changed_lines

        changed = result.changed_episodes
        links = [f"{base_url}{e.player}" if e.player else None for e in changed]
        lines += [
            "",
            f"episodes that ended otherwise ({len(changed)}; each with its side-by-side player where both "
            "kept the trace):",
            *changed_lines(list(changed), links),
        ]
    return "\n".join(lines)


CONFIG_LINES = 30  #: differing config keys printed before "... N more"
#: the stage config repeats the planner's config under this prefix; the run setup names it ``planner.``
STAGE_PLANNER = "stage.planner.config."


def config_keys(diff: dict[str, Sides]) -> dict[str, Sides]:
    """The differing keys, each once: a ``stage.planner.config.K`` whose change ``planner.K`` already shows is
    left out."""

    def repeated(key: str, v: Sides) -> bool:
        twin = "planner." + key.removeprefix(STAGE_PLANNER)
        return key.startswith(STAGE_PLANNER) and twin in diff and diff[twin] == v

    return {key: v for key, v in diff.items() if not repeated(key, v)}


def _method(m: Delta) -> str:
    if m.method != "paired":
        return "unpaired (MOVER)"
    extra = f", discordant A/B {m.discordant[0]}/{m.discordant[1]}" if m.discordant else ""
    return f"paired n={m.n_pairs}, {m.test} p={_num(m.p_value)}{extra}"


def _value(estimate: Estimate) -> str:
    """``value [low, high]`` of an estimate."""
    ci = f" [{_num(estimate.low)}, {_num(estimate.high)}]" if estimate.low is not None else ""
    return _num(estimate.value) + ci


def _short(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _num(value: Any) -> str:
    return f"{value:.3f}" if isinstance(value, int | float) else "-"
