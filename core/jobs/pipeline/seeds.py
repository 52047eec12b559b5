"""Mining seed manifests: (scenario, seed) pairs where a baseline planner fails.

Two manifests, never mixed up: the EVALUATION hard seeds (diagnostics, campaign hard suite,
gates) are mined from the matrix's own seeds (the seeds evaluations run), the TRAINING hard seeds
(hard-case collection, proxy selection) from a separate seed range outside every evaluation seed, with the
evaluation manifest excluded. ``foresight pipeline mine-seeds`` reproduces the shipped manifests
(``configs/seeds/``); the exact commands are in each file's header.

The shipped manifests are mined with the social-force baseline: it is deterministic (the same seed gives the
same episode). ORCA would be the natural baseline, but when they were mined its episodes differed from run to
run in one process (fixed since in the ORCA planner); re-mining with ``--baseline orca`` is now possible but
would change the manifests.
Seed ranges: evaluation = each scenario's own matrix seeds (1000-2009 in classic_interactions), training =
20000-20039 (``--seeds 20000:20040``); base collection in the pipelines starts at 50000 + 100000 per scenario.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import yaml

from foresight.core import files
from foresight.core.errors import ConfigError
from foresight.core.yamlio import load_yaml

#: Seeds below this are the evaluation range of our matrices (their own seeds, extended by
#: ``seeds_per_scenario``); training seeds are mined at or above :data:`TRAINING_SEED_MIN`.
EVALUATION_SEED_MAX = 9_999
TRAINING_SEED_MIN = 20_000


def parse_seed_range(text: str) -> list[int]:
    """``"20000:20040"`` (half open) or ``"1,5,9"`` -> seeds."""
    text = text.strip()
    try:
        if ":" in text:
            lo, hi = (int(x) for x in text.split(":", 1))
            if hi <= lo or lo < 0:
                raise ValueError
            return list(range(lo, hi))
        return [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ConfigError(
            f"seed range {text!r}: give LO:HI (half open, 0 <= LO < HI) or a comma list", item="seeds"
        ) from None


def mine_failures(
    matrix_path: str | Path,
    *,
    seeds: Sequence[int] | None,
    baseline: str = "orca",
    baseline_config: dict[str, Any] | None = None,
    per_scenario: int = 2,
    scenarios: Iterable[str] | None = None,
    exclude: Iterable[tuple[str, int]] = (),
    max_steps: int | None = None,
    progress: Callable[[float, str], None] | None = None,
) -> dict[str, list[int]]:
    """Scenario -> the first ``per_scenario`` seeds (in order) where ``baseline`` does not reach the goal.

    ``seeds``: the candidate seeds of every scenario (None: each scenario's own seeds from the matrix).
    ``exclude``: pairs never to pick (e.g. the evaluation manifest when mining training seeds).
    Deterministic: the simulator and the baselines draw only from the episode seed.
    """
    from foresight.core.planners.registry import make_planner
    from foresight.core.scenarios.loader import load_matrix
    from foresight.core.sim.episode import run_episode

    if baseline == "predictive":
        raise ConfigError(
            "mine with a baseline that needs no model (orca, social_force, goal)", item="baseline"
        )
    matrix = load_matrix(Path(matrix_path))
    names = [matrix.get(n).name for n in scenarios] if scenarios else list(matrix.names)
    excluded = set(exclude)
    out: dict[str, list[int]] = {}
    for i, name in enumerate(names):
        resolved = matrix.get(name)
        candidates = list(seeds) if seeds is not None else list(resolved.scenario.seeds)
        found: list[int] = []
        for seed in candidates:
            if len(found) >= per_scenario:
                break
            if (name, seed) in excluded:
                continue
            result = run_episode(resolved, seed, make_planner(baseline, baseline_config), max_steps=max_steps)
            if result.outcome != "success":
                found.append(int(seed))
        if found:
            out[name] = found
        if progress is not None:
            progress((i + 1) / len(names), f"{name}: {len(found)} failing seeds")
    return out


def manifest_pairs(data: dict[str, Any]) -> set[tuple[str, int]]:
    """(scenario, seed) pairs of a manifest's parsed YAML (plain or ``{seeds: ...}`` form)."""
    seeds = data.get("seeds") if isinstance(data.get("seeds"), dict) else data
    return {(str(name), int(seed)) for name, values in seeds.items() for seed in values}


def read_manifest_pairs(path: str | Path) -> set[tuple[str, int]]:
    data = load_yaml(Path(path).read_text(), source=path)
    if not isinstance(data, dict):
        raise ConfigError("a seed manifest must be a mapping", source=path)
    return manifest_pairs(data)


def write_manifest(path: str | Path, seeds: dict[str, list[int]], description: str, header: str = "") -> Path:
    """Write the wrapped manifest form (``description`` + ``seeds``) with a comment header."""
    path = Path(path)
    body = yaml.safe_dump(
        {"description": description, "seeds": seeds}, sort_keys=False, default_flow_style=None, width=120
    )
    comment = "".join(f"# {line}".rstrip() + "\n" for line in header.strip().splitlines()) if header else ""
    files.write_text(path, comment + body)
    return path
