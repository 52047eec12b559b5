"""Integrity checks on a set of episode records; any violation fails the evaluation (never passes silently).

The reference could report a "success" that collided and could run a constant-velocity fallback under
the name of the learned planner; these checks make both impossible to miss.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable

from pydantic import BaseModel, Field

from foresight.core.evaluation.record import EpisodeRecord

#: tolerance on a negative clearance before a "success" counts as an undetected overlap [m]
OVERLAP_TOL = 1e-6


class Violation(BaseModel):
    check: str  #: success_with_collision | missing_provenance | silent_fallback | label_mismatch | duplicate | missing_episode
    scenario: str | None = None
    seed: int | None = None
    message: str


class IntegrityReport(BaseModel):
    ok: bool
    checks: list[str]  #: the checks that ran
    violations: list[Violation] = Field(default_factory=list)


CHECKS = [
    "success_with_collision",
    "missing_provenance",
    "silent_fallback",
    "label_mismatch",
    "duplicate",
    "missing_episode",
]


def _record_violations(r: EpisodeRecord) -> Iterable[Violation]:
    def v(check: str, message: str) -> Violation:
        return Violation(check=check, scenario=r.scenario, seed=r.seed, message=message)

    if r.outcome == "success":
        if r.collision_kind is not None or r.safety.first_collision_step is not None:
            yield v("success_with_collision", f"success with a {r.collision_kind or 'recorded'} collision")
        if r.safety.min_clearance is not None and r.safety.min_clearance < -OVERLAP_TOL:
            yield v(
                "success_with_collision",
                f"success, but the trace overlaps a pedestrian (clearance {r.safety.min_clearance:.3f} m)",
            )
    p = r.provenance
    missing = [
        name
        for name in ("scenario", "planner_config_hash", "model_id", "checkpoint_sha256", "code_version")
        if not getattr(p, name)
    ]
    if not p.dt or p.dt <= 0:
        missing.append("dt")
    if missing:
        yield v("missing_provenance", f"provenance lacks {', '.join(missing)}")
    if p.fallback:
        yield v("silent_fallback", f"planner {p.planner!r} fell back: {p.fallback}")
    if (r.outcome == "success") != (r.taxonomy.label is None):
        yield v("label_mismatch", f"outcome {r.outcome} with taxonomy label {r.taxonomy.label}")


def check_integrity(
    records: list[EpisodeRecord], expected: Iterable[tuple[str, int]] | None = None
) -> IntegrityReport:
    """Run every check; ``expected`` lists the (scenario, seed) episodes that were requested."""
    violations = [v for r in records for v in _record_violations(r)]
    keys = Counter((r.scenario, r.seed, r.planner, r.variant, r.provenance.model_id) for r in records)
    for (scenario, seed, *_), n in keys.items():
        if n > 1:
            violations.append(
                Violation(check="duplicate", scenario=scenario, seed=seed, message=f"{n} records")
            )
    if expected is not None:
        have = {(r.scenario, r.seed) for r in records}
        for scenario, seed in expected:
            if (scenario, seed) not in have:
                violations.append(
                    Violation(
                        check="missing_episode",
                        scenario=scenario,
                        seed=seed,
                        message="requested episode has no record",
                    )
                )
    return IntegrityReport(ok=not violations, checks=list(CHECKS), violations=violations)
