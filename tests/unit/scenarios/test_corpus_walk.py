"""Walk the reference's whole scenario corpus: every matrix loads, every scenario runs one short episode.

Files that are not matrices are refused by kind (``test_corpus_kinds``); files that name a file
the corpus does not ship (a suite kept back for independent evaluation) fail with one line naming
it; two matrices are refused by what they ask for (several robots; robot routes through
pedestrian-only infrastructure, which robot_sf's certification fixtures expect to be rejected).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from foresight.core.errors import ConfigError
from foresight.core.planners.registry import make_planner
from foresight.core.scenarios.loader import load_matrix
from foresight.core.sim.episode import run_episode
from foresight.core.sim.simulator import Simulator

WALK_STEPS = (
    20  #: steps per episode: every scenario's set-up, behaviours and planner run, not its whole horizon
)

#: matrices that name a file the corpus leaves out (PROVENANCE.md: a suite kept back) -> that file
WITHHELD = {
    "issue_6481_social_compliance_preflight.yaml": "sets/verified_simple_subset_v1.yaml",
    "nominal_v1.yaml": "sets/verified_simple_subset_v1.yaml",
    "sanity_v1.yaml": "sets/verified_simple_subset_v1.yaml",
    "sets/issue_3300_false_positive_single_ped_smoke.yaml": "sets/verified_simple_subset_v1.yaml",
    "sets/atomic_navigation_minimal_full_v1.yaml": "archetypes/issue_596_dynamic.yaml",
    "sets/issue_3202_ammv_anticipatory_conflict.yaml": "single/issue_2527_waiting_then_crossing.yaml",
    "sets/issue_3320_occluded_emergence_live_replay.yaml": "single/issue_2756_occluded_emergence_live.yaml",
    "sets/issue_3323_occluded_emergence_near_field_live_replay.yaml": "single/issue_3323_occluded_emergence_near_field_live.yaml",
    "sets/issue_3556_near_safe_occlusion_bearing_crossing.yaml": "single/issue_3556_near_safe_occlusion_bearing_crossing.yaml",
    "sets/issue_3635_near_safe_occlusion_bearing_crossing.yaml": "single/issue_3635_near_safe_occlusion_bearing_crossing.yaml",
    "sets/issue_3977_public_requirements.yaml": "single/issue_3977_safe_braking.yaml",
    "sets/ppo_all_available_training_v1_horizon500.yaml": "sets/ppo_all_available_training_v1.yaml",
    "single/ovgu_campus_walk.yaml": "../../../maps/imported/ovgu_campus_walk.yaml",
}
_ISSUE_596 = ("east", "north", "northeast", "northwest", "south", "southeast", "southwest", "west")
#: files that are not scenario matrices -> their kind
KINDS = {
    "archetype_validation_waivers.yaml": "validation waiver list",
    "archetypes/classic_density_tier_index.yaml": "density-tier index",
    "collision_sanity.yaml": "parametric scenario-generator spec",
    "sets/issue_3279_social_mini_game_families_v0.yaml": "parametric scenario-generator spec",
    "contracts/issue_2164_amv_cross_trap_contracts.yaml": "scenario contract set",
    "contracts/issue_3813_sustained_flow_contracts.yaml": "scenario contract set",
    "contracts/station_platform_candidate_pack_issue736_contracts.yaml": "scenario contract set",
    "contracts/issue_6054_regulation_source_example.yaml": "regulation record",
    "generated/issue_4932_rare_event_demo_archive.yaml": "generated-scenario catalog",
    "generated/issue_5264_generated_replay_catalog.yaml": "generated-scenario catalog",
    "generated/issue_5264_review_manifest.yaml": "generated-scenario review manifest",
    "lightweight_cnn_issue_835_repro.yaml": "training run config",
    **{f"multi_extractor_{n}.yaml": "training run config" for n in ("default", "eval_193", "gpu")},
    **{
        f"maps/issue_2926_{n}.yaml": "map definition"
        for n in ("pedestrian_only_cut", "signalized_crossing_wait_box", "stair_access")
    },
    "perturbations/issue_3369_occluder_timing_pilot_v1.yaml": "perturbation manifest",
    "results/performance_smoke_test.json": "result index",
    "route_overrides/issue_1878/classic_head_on_corridor_low_guided_1502.yaml": "route-override payload",
    "route_overrides/issue_3323/occluded_emergence_near_field_h1.yaml": "route-override payload",
    **{
        f"route_overrides/issue_3977/{n}.yaml": "route-override payload"
        for n in ("emergency_reaction", "safe_braking", "visibility_and_intent")
    },
    **{
        f"route_overrides/issue_596/{n}.yaml": "route-override payload"
        for n in (*(f"empty_goal_{d}" for d in _ISSUE_596), "goal_behind_robot", "small_angle_precision")
    },
}
#: matrices refused for what they ask -> the words of the refusal
REFUSED = {
    "single/multi_amv_minimal_smoke.yaml": "multi_amv: Foresight simulates one robot",
    "sets/issue_2926_shared_space_infrastructure_smoke.yaml": "enters infrastructure zone 'pedestrian_only_cut'",
}
#: scenarios built to be invalid -> the words of the error their episode start gives
INVALID_SCENARIOS = {"goal_inside_obstacle_invalid": "could not place 1 points in robot goal zone"}


@pytest.fixture(scope="module")
def corpus(corpus_dir: Path) -> dict[str, object]:
    """Every YAML/JSON file under configs/scenarios -> its loaded matrix or the ConfigError it raised."""
    root = corpus_dir / "configs/scenarios"
    out: dict[str, object] = {}
    for path in sorted([*root.rglob("*.yaml"), *root.rglob("*.json")]):
        try:
            out[path.relative_to(root).as_posix()] = load_matrix(path)
        except ConfigError as err:
            out[path.relative_to(root).as_posix()] = err
    return out


def test_every_matrix_loads_or_says_in_one_line_why_not(corpus: dict[str, object]) -> None:
    kinds, withheld, refused, loaded = {}, {}, {}, []
    for rel, got in corpus.items():
        if not isinstance(got, ConfigError):
            loaded.append(rel)
            continue
        text = str(got)
        assert "\n" not in text
        if m := re.search(r": not a scenario matrix \(it is a (.+)\)$", text):
            kinds[rel] = m.group(1)
        elif m := re.search(r"(?:file|map_file) '(.+?)' (?:does not exist|not found)", text):
            withheld[rel] = m.group(1)
        else:
            refused[rel] = text
    assert {rel: w.split("configs/scenarios/")[-1] for rel, w in withheld.items()} == WITHHELD
    assert set(refused) == set(REFUSED)
    for rel, words in REFUSED.items():
        assert words in refused[rel]
    assert kinds == KINDS
    assert len(corpus) == 118 and len(loaded) == 118 - len(KINDS) - len(WITHHELD) - len(REFUSED) == 68
    assert "classic_interactions.yaml" in loaded and "event_disruption.yaml" in loaded


def test_every_scenario_runs_one_episode_with_the_predictive_planner(corpus: dict[str, object]) -> None:
    # exact static distance queries: the per-map distance table of some corpus maps (1500 edges) costs minutes
    planner = make_planner("predictive", {"safety": {"static": {"field_resolution": 0.0}}}, model="cv")
    sim, seen, ran = Simulator(), set(), 0
    for got in corpus.values():
        if isinstance(got, ConfigError):
            continue
        for scen in got.scenarios:
            key = (scen.name, scen.map_sha256, scen.scenario.model_dump_json(), scen.map.model_dump_json())
            if key in seen:
                continue
            seen.add(key)
            if scen.name in INVALID_SCENARIOS:
                with pytest.raises(ConfigError, match=INVALID_SCENARIOS[scen.name]):
                    run_episode(scen, scen.scenario.seeds[0], planner, max_steps=WALK_STEPS, simulator=sim)
                continue
            result = run_episode(scen, scen.scenario.seeds[0], planner, max_steps=WALK_STEPS, simulator=sim)
            assert result.steps >= 1 and result.outcome in (
                "success",
                "collision_pedestrian",
                "collision_static",
                "timeout",
            )
            ran += 1
    assert ran >= 100
