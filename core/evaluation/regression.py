"""The regression gate: a candidate against the model it would replace (the incumbent), on the same episodes;
and the floors gate: a candidate against constant velocity measured in the same run.

Both compare episode by episode where the two runs hold the same (scenario, seed) episodes: the drop in success
(rise in collisions) must not exceed a tolerance, and the one-sided exact McNemar test on the discordant pairs
must not say "worse" at ``alpha``. A check says its value, threshold and the paired test, so a person reads why
a model was or was not promoted.
"""

from __future__ import annotations

from collections.abc import Sequence

from pydantic import BaseModel, ConfigDict, Field

from foresight.core.evaluation.delta import EpisodeChange, changed_episodes, pair_keys
from foresight.core.evaluation.gates import GateCheck, GateResult, TaxonomyComparison, compare_taxonomy
from foresight.core.evaluation.record import EpisodeRecord
from foresight.core.evaluation.stats import ALPHA


def mcnemar_worse_p(worse: int, better: int) -> float:
    """One-sided exact McNemar p-value that the candidate is worse: P(X >= worse) for X ~ Bin(worse + better, 1/2),
    ``worse`` = pairs only the incumbent got right, ``better`` = pairs only the candidate got right."""
    n = worse + better
    if n == 0:
        return 1.0
    from scipy.stats import binomtest

    return float(binomtest(worse, n, 0.5, alternative="greater").pvalue)


class RegressionGateConfig(BaseModel):
    """Tolerances of the candidate against the incumbent (drops are incumbent - candidate, as rates)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    max_success_drop: float = Field(default=0.0, ge=0, le=1)  #: global success may fall by at most this
    max_collision_rise: float = Field(default=0.0, ge=0, le=1)  #: global collisions may rise by at most this
    max_hard_success_drop: float = Field(
        default=0.0, ge=0, le=1
    )  #: hard seeds solved (share) may fall by this
    alpha: float = Field(default=ALPHA, gt=0, lt=1)  #: one-sided McNemar level for "worse"
    fail_on_new_failure_labels: bool = False  #: new failure mechanisms are always flagged; fail on them too


class PairedRate(BaseModel):
    """One binary metric of two runs over the same episodes."""

    candidate: float | None
    incumbent: float | None
    n_pairs: int
    worse: int  #: pairs where only the candidate is worse (fails / collides)
    better: int  #: pairs where only the candidate is better
    p_worse: float | None  #: one-sided McNemar p that the candidate is worse (None: unpaired)


class RegressionGateResult(GateResult):
    candidate: str
    incumbent: str
    incumbent_sha256: str | None = None
    success: PairedRate | None = None
    collision: PairedRate | None = None
    hard_solved: tuple[int, int, int] | None = None  #: (candidate solved, incumbent solved, hard seeds)
    taxonomy: TaxonomyComparison | None = None  #: global suite, candidate vs incumbent
    hard_taxonomy: TaxonomyComparison | None = None
    changed: list[EpisodeChange] = Field(
        default_factory=list
    )  #: every episode that ended otherwise (a = incumbent)
    hard_changed: list[EpisodeChange] = Field(default_factory=list)
    #: the two evaluations' ids where the service ran them (the side-by-side player's operands: a = incumbent)
    candidate_run: str | None = None
    incumbent_run: str | None = None


def paired_rate(
    candidate: Sequence[EpisodeRecord], reference: Sequence[EpisodeRecord], metric: str
) -> PairedRate | None:
    """``metric`` (success or collision) of both runs; None unless they ran exactly the same episodes."""
    if not candidate or pair_keys(candidate) != pair_keys(reference):
        return None
    ref = {(r.scenario, r.seed): r for r in reference}
    good = (lambda r: r.success) if metric == "success" else (lambda r: not r.collision)
    worse = better = 0
    for r in candidate:
        c, i = good(r), good(ref[(r.scenario, r.seed)])
        worse += int(i and not c)
        better += int(c and not i)
    n = len(candidate)
    value = (lambda r: r.success) if metric == "success" else (lambda r: r.collision)
    return PairedRate(
        candidate=sum(map(value, candidate)) / n,
        incumbent=sum(map(value, reference)) / n,
        n_pairs=n,
        worse=worse,
        better=better,
        p_worse=mcnemar_worse_p(worse, better),
    )


def _check(name: str, pr: PairedRate | None, tolerance: float, alpha: float, rise: bool = False) -> GateCheck:
    if pr is None:
        return GateCheck(
            name=name,
            passed=False,
            detail="the two runs did not hold the same episodes: no paired comparison",
        )
    assert pr.candidate is not None and pr.incumbent is not None
    change = (pr.candidate - pr.incumbent) if rise else (pr.incumbent - pr.candidate)
    significant = pr.p_worse is not None and pr.p_worse < alpha
    return GateCheck(
        name=name,
        passed=change <= tolerance + 1e-12 and not significant,
        value=change,
        threshold=tolerance,
        detail=(
            f"candidate {pr.candidate:.3f} vs incumbent {pr.incumbent:.3f} over {pr.n_pairs} paired episodes; "
            f"worse in {pr.worse}, better in {pr.better}; one-sided McNemar p={pr.p_worse:.3g}"
            + (f" < {alpha}: significantly worse" if significant else "")
        ),
    )


def regression_gate(
    candidate: tuple[str, Sequence[EpisodeRecord]],
    incumbent: tuple[str, str | None, Sequence[EpisodeRecord]],
    cfg: RegressionGateConfig,
    hard: tuple[Sequence[tuple[str, int, str, str | None]], Sequence[tuple[str, int, str, str | None]]]
    | None = None,
) -> RegressionGateResult:
    """``candidate`` (label, global records); ``incumbent`` (id, sha256, global records on the same episodes);
    ``hard``: (candidate, incumbent) hard-seed outcomes as (scenario, seed, outcome, failure label)."""
    cname, crec = candidate
    iname, isha, irec = incumbent
    success = paired_rate(crec, irec, "success")
    collision = paired_rate(crec, irec, "collision")
    tax = compare_taxonomy(_labels(crec), _labels(irec))
    checks = [
        _check("success_vs_incumbent", success, cfg.max_success_drop, cfg.alpha),
        _check("collision_vs_incumbent", collision, cfg.max_collision_rise, cfg.alpha, rise=True),
    ]
    hard_solved, hard_tax, hard_changed = None, None, []
    if hard is not None:
        ch, ih = hard
        keys_c, keys_i = sorted(h[:2] for h in ch), sorted(h[:2] for h in ih)
        cs, is_ = sum(h[2] == "success" for h in ch), sum(h[2] == "success" for h in ih)
        hard_solved = (cs, is_, len(ch))
        hard_tax = compare_taxonomy(
            _count(h[3] for h in ch if h[2] != "success" and h[3]),
            _count(h[3] for h in ih if h[2] != "success" and h[3]),
        )
        drop = (is_ - cs) / len(ch) if ch else 0.0
        checks.append(
            GateCheck(
                name="hard_success_vs_incumbent",
                passed=keys_c == keys_i and drop <= cfg.max_hard_success_drop + 1e-12,
                value=drop,
                threshold=cfg.max_hard_success_drop,
                detail=f"solved {cs}/{len(ch)} hard seeds vs the incumbent's {is_}/{len(ih)}"
                + ("" if keys_c == keys_i else "; the two ran different hard seeds"),
            )
        )
        by = {(s, seed): o for s, seed, o, _ in ih}
        hard_changed = [
            EpisodeChange(scenario=s, seed=seed, a=by[(s, seed)], b=o)
            for s, seed, o, _ in sorted(ch)
            if (s, seed) in by and by[(s, seed)] != o
        ]
    new = list(dict.fromkeys([*tax.new_labels, *(hard_tax.new_labels if hard_tax else [])]))
    checks.append(
        GateCheck(
            name="new_failure_mechanisms",
            passed=not (cfg.fail_on_new_failure_labels and new),
            value=float(len(new)),
            threshold=0.0 if cfg.fail_on_new_failure_labels else None,
            detail=(", ".join(new) + ("" if cfg.fail_on_new_failure_labels else " (flagged, not failing)"))
            if new
            else "none",
        )
    )
    return RegressionGateResult(
        passed=all(c.passed for c in checks),
        checks=checks,
        candidate=cname,
        incumbent=iname,
        incumbent_sha256=isha,
        success=success,
        collision=collision,
        hard_solved=hard_solved,
        taxonomy=tax,
        hard_taxonomy=hard_tax,
        changed=changed_episodes(irec, crec) or [],
        hard_changed=hard_changed,
    )


def _count(labels: object) -> dict[str, int]:
    out: dict[str, int] = {}
    for label in labels:  # type: ignore[attr-defined]
        out[label] = out.get(label, 0) + 1
    return out


def _labels(records: Sequence[EpisodeRecord]) -> dict[str, int]:
    """Failure mechanism counts of a run's failed episodes (their taxonomy label)."""
    return _count(r.taxonomy.label for r in records if not r.success and r.taxonomy.label)


class FloorsConfig(BaseModel):
    """Floors measured in the same run: constant velocity's success on the same episodes, its ADE/FDE on the same
    validation windows (the training result's ``cv_val_*``)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    max_success_below_cv: float = Field(
        default=0.0, ge=0, le=1
    )  #: candidate success may be this far below CV's
    require_ade_below_cv: bool = True
    require_fde_below_cv: bool = True
    alpha: float = Field(default=ALPHA, gt=0, lt=1)


def floors_gate(
    candidate: Sequence[EpisodeRecord],
    cv: Sequence[EpisodeRecord],
    cfg: FloorsConfig,
    ade: tuple[float | None, float | None] | None = None,
    fde: tuple[float | None, float | None] | None = None,
) -> GateResult:
    """``ade``/``fde``: (candidate, constant velocity) on the validation windows (None: no training in this run)."""
    checks = [
        _check(
            "success_vs_constant_velocity",
            paired_rate(candidate, cv, "success"),
            cfg.max_success_below_cv,
            cfg.alpha,
        )
    ]
    for name, pair, required in (
        ("ade", ade, cfg.require_ade_below_cv),
        ("fde", fde, cfg.require_fde_below_cv),
    ):
        if pair is None or not required:
            continue
        mine, theirs = pair
        ok = mine is not None and theirs is not None and mine < theirs
        checks.append(
            GateCheck(
                name=f"val_{name}_below_constant_velocity",
                passed=ok,
                value=mine,
                threshold=theirs,
                detail="" if mine is not None and theirs is not None else "not measured",
            )
        )
    return GateResult(passed=all(c.passed for c in checks), checks=checks)
