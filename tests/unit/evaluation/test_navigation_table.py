"""bench/navigation_table.py: the paired learned-vs-constant-velocity comparison each suite reports, and its suites."""

from __future__ import annotations

import subprocess
import sys

from tests.unit.bench_scripts import BENCH as BENCH_DIR
from tests.unit.bench_scripts import load_bench
from tests.unit.evaluation.traces import record

BENCH = BENCH_DIR / "navigation_table.py"


def _runs(outcomes: str, scenario: str = "s_low") -> list:
    """One record per character: s = success, c = collision, t = timeout; seeds 0, 1, ..."""
    kind = {"s": "success", "c": "collision_pedestrian", "t": "timeout"}
    return [record(scenario, seed, kind[o]) for seed, o in enumerate(outcomes)]


def test_learned_vs_cv_counts_failures_and_discordant_pairs_on_common_episodes() -> None:
    nav = load_bench("navigation_table")
    learned = _runs("s" * 20 + "sssct")  # 25 episodes, 2 failures
    cv = _runs("s" * 20 + "ccsst") + _runs(
        "t", scenario="only_cv"
    )  # an episode learned never ran: not a pair
    c = nav.learned_vs_cv(learned, cv)
    assert (c["pairs"], c["failed_learned"], c["failed_cv"]) == (25, 2, 3)
    assert (c["learned_only"], c["cv_only"]) == (2, 1)  # seeds 21, 22 : seed 23
    assert c["fewer_failures"] == round(1 - 2 / 3, 3)
    assert c["mcnemar_p"] == 1.0  # 2 : 1 is no evidence


def test_no_p_value_below_the_minimum_number_of_pairs() -> None:
    nav = load_bench("navigation_table")
    c = nav.learned_vs_cv(_runs("sssss"), _runs("ccccc"))
    assert (c["learned_only"], c["cv_only"], c["mcnemar_p"]) == (5, 0, None)


def test_every_suite_has_replication_seeds_and_bad_arguments_are_refused() -> None:
    nav = load_bench("navigation_table")
    for name in nav.DEFAULT_SUITES:
        assert nav.REPLICATION[nav.SUITES[name][0]].is_file()
    bad = subprocess.run(
        [sys.executable, str(BENCH), "--suites", "stress,no_such_suite"], capture_output=True, text=True
    )
    assert bad.returncode == 2 and "unknown suite 'no_such_suite'" in bad.stderr
    both = subprocess.run(
        [sys.executable, str(BENCH), "--matrix", "m.yaml", "--replication"], capture_output=True, text=True
    )
    assert both.returncode == 2 and "does not apply to --matrix" in both.stderr


def test_crowdnav_suites_run_the_published_baseline_configs_and_have_no_replication() -> None:
    nav = load_bench("navigation_table")
    assert nav.SUITE_GROUPS["crowdnav"] == list(nav.CROWDNAV_SUITES)
    for name, (matrix, _) in nav.CROWDNAV_SUITES.items():
        assert matrix.is_file()
        for planner in ("orca", "social_force"):
            args = nav.planner_args(name, planner)
            assert args[0] == "--planner" and args[1].endswith(".yaml") and "crowdnav" in args[1]
    assert nav.planner_args("crowdnavpp_rand", "orca")[1].endswith("orca_pp.yaml")
    assert nav.planner_args("crowdnav_circle", "orca")[1].endswith("/orca.yaml")
    assert nav.planner_args("stress", "orca") == ["--planner", "orca"]
    rep = subprocess.run(
        [sys.executable, str(BENCH), "--suites", "crowdnav", "--replication"], capture_output=True, text=True
    )
    assert rep.returncode == 2 and "no replication seeds" in rep.stderr
