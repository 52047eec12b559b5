"""A finished job in a few lines, what a reader came for first: status and verdict, the headline numbers, the failed
gate checks, the artifacts and where the report is. `submit --wait`, `jobs wait` and `jobs show` print it."""

from __future__ import annotations

from typing import Any

from pydantic import ValidationError

from foresight.schemas import JobPublic

MAX_ARTIFACTS = 12  #: artifact names listed before "... and N more"
SKIP = {"exit_code", "code_version"}  #: result fields the summary leaves to --json


def _value(x: Any) -> str:
    if isinstance(x, float):
        return f"{x:.4g}"
    return str(x)


def headline(result: dict[str, Any]) -> list[str]:
    """The result's top-level scalar fields (rates, counts, names), then its gate checks that failed."""
    scalars = [
        f"{k} {_value(v)}"
        for k, v in result.items()
        if k not in SKIP and isinstance(v, int | float | str | bool) and not isinstance(v, dict)
    ]
    lines = []
    for i in range(0, len(scalars), 4):
        lines.append("  " + ", ".join(scalars[i : i + 4]))
    if "gate" not in result:  # the results with a gate (evaluate, campaign) load the evaluation stack
        return lines
    from foresight.core.evaluation.gates import GateResult

    try:
        gate = GateResult.model_validate(result["gate"]) if result["gate"] is not None else None
    except ValidationError:  # a "gate" of another shape: the scalars say enough, --json has all
        gate = None
    for check in gate.checks if gate is not None else ():
        if not check.passed:
            lines.append(
                f"  gate {check.name}: FAIL ({_value(check.value)} vs {_value(check.threshold)}) "
                f"{check.detail}".rstrip()
            )
    return lines


def job_summary(job: JobPublic, base_url: str) -> str:
    """Status line, error or verdict, headline, artifacts and the report's places, in that order."""
    out = [
        f"{job.kind} job {job.id}: {job.status}"
        + (f", verdict {job.verdict}" if job.verdict else "")
        + (f"  {job.name!r}" if job.name else "")
    ]
    if job.note:
        out.append(f"note: {job.note}")
    if job.error:
        out.append(f"error: {job.error.type}: {job.error.message}")
    if job.result is not None:
        out += headline(job.result)
    names = [a.name for a in job.artifacts or []]
    if names:
        more = f" ... and {len(names) - MAX_ARTIFACTS} more" if len(names) > MAX_ARTIFACTS else ""
        out.append(f"artifacts ({len(names)}): {', '.join(names[:MAX_ARTIFACTS])}{more}")
    children = job.children or []
    if children:
        out.append(f"children ({len(children)}): " + ", ".join(c[:12] for c in children))
    out.append(
        f"page: {base_url}/ui/jobs/{job.id}"
        + ("  report: `foresight report " + job.id[:12] + "`" if "report.md" in names else "")
    )
    return "\n".join(out)
