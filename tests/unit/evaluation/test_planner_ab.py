"""bench/planner_ab.py: paired outcome counts of planner variants per suite, a real run, and refused arguments."""

from __future__ import annotations

import json
import subprocess
import sys

from tests.unit.bench_scripts import BENCH as BENCH_DIR
from tests.unit.bench_scripts import load_bench

BENCH = BENCH_DIR / "planner_ab.py"


def _rows(variant: str, outcomes: str, suite: str = "stress") -> list[dict]:
    """One row per character: s = success, c = collision, t = timeout; seeds 0, 1, ..."""
    kind = {"s": "success", "c": "collision_pedestrian", "t": "timeout"}
    return [
        {"variant": variant, "suite": suite, "scenario": "x", "seed": i, "outcome": kind[o]}
        for i, o in enumerate(outcomes)
    ]


def test_each_variant_is_counted_and_paired_with_the_first_on_the_same_episodes() -> None:
    ab = load_bench("planner_ab")
    rows = _rows("base", "s" * 20 + "ssct") + _rows("new", "s" * 20 + "ccss")
    out = ab.summary(rows, ["base", "new"])["stress"]
    assert out["variants"]["base"] == {
        **out["variants"]["base"],
        "episodes": 24,
        "success": 22,
        "collision": 1,
        "timeout": 1,
    }
    assert out["variants"]["new"]["success"] == 22 and out["variants"]["new"]["collision"] == 2
    paired = out["paired"]["new"]
    assert (paired["first_only"], paired["variant_only"]) == (2, 2)  # seeds 20, 21 : 22, 23
    assert (paired["collisions_first_only"], paired["collisions_variant_only"]) == (
        1,
        2,
    )  # seed 22 : seeds 20, 21
    assert paired["mcnemar_p"] == 1.0 and len(paired["changed"]) == 4
    few = ab.summary(_rows("base", "ssss") + _rows("new", "cccc"), ["base", "new"])["stress"]["paired"]["new"]
    assert (few["first_only"], few["mcnemar_p"]) == (4, None)  # no significance mark below MIN_PAIRS pairs


def test_the_same_variant_twice_reads_the_same_episodes(tmp_path) -> None:
    done = subprocess.run(
        [
            sys.executable,
            str(BENCH),
            "--variant",
            "a={}",
            "--variant",
            'b={"weights": {"goal": 6.0}}',
            "--suites",
            "reference_defaults",
            "--scenarios",
            "classic_doorway_low",
            "--seeds-per-scenario",
            "1",
            "--workers",
            "2",
            "--variant",
            'cv={"model": "cv"}',
            "--out",
            str(tmp_path),
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    suite = json.loads(done.stdout)["suites"]["reference_defaults"]
    assert suite["variants"]["a"]["episodes"] == suite["variants"]["b"]["episodes"] == 1
    assert suite["paired"]["b"]["changed"] == [] and suite["paired"]["b"]["mcnemar_p"] is None
    assert (
        suite["paired"]["cv"]["pairs"] == 1
    )  # a variant with its own model (constant velocity) is paired too
    assert len((tmp_path / "episodes.jsonl").read_text().splitlines()) == 3


def test_bad_arguments_are_refused_in_one_line() -> None:
    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, str(BENCH), *args], capture_output=True, text=True, timeout=300
        )

    bad_json = run("--variant", "a={not json")
    assert bad_json.returncode != 0 and "--variant a: not JSON" in bad_json.stderr
    suite = run("--variant", "a={}", "--suites", "stress,no_such_suite")
    assert suite.returncode == 2 and "unknown suite 'no_such_suite'" in suite.stderr
    key = run("--variant", 'a={"sampling": {"no_such_key": 1}}', "--suites", "reference_defaults")
    assert key.returncode != 0 and "no_such_key" in key.stderr
    scenario = run("--variant", "a={}", "--suites", "reference_defaults", "--scenarios", "no_such_scenario")
    assert scenario.returncode != 0 and "no scenario 'no_such_scenario'" in scenario.stderr
    path_like = run("--variant", "a/../../x={}")  # a name is a folder name of --players: no path in it
    assert path_like.returncode != 0 and "NAME of letters, digits" in path_like.stderr
    players = run(
        "--variant",
        "a={}",
        "--suites",
        "reference_defaults",
        "--scenarios",
        "classic_doorway_low",
        "--players",
        "/proc/no_such_folder",
    )  # refused before any episode runs
    assert players.returncode != 0 and "--players /proc/no_such_folder: cannot write there" in players.stderr
    assert "episodes" not in players.stderr and len(players.stderr.strip().splitlines()) == 1


def test_players_show_the_changed_episodes_side_by_side(tmp_path) -> None:
    """--players: a variant crawling at 5 % of the speed times out where the first succeeds; that episode is written
    as one page holding both runs (and the temporary traces are gone)."""
    import tempfile
    from pathlib import Path

    before = set(Path(tempfile.gettempdir()).glob("planner_ab_traces_*"))
    done = subprocess.run(
        [
            sys.executable,
            str(BENCH),
            "--variant",
            "a={}",
            "--variant",
            'slow={"max_speed_ratio": 0.05}',
            "--suites",
            "reference_defaults",
            "--scenarios",
            "classic_head_on_corridor_low",
            "--seeds-per-scenario",
            "1",
            "--workers",
            "2",
            "--players",
            str(tmp_path / "p"),
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    paired = json.loads(done.stdout)["suites"]["reference_defaults"]["paired"]["slow"]
    assert paired["changed"] == [["classic_head_on_corridor_low", 111, "success", "timeout"]]
    assert paired["players"] == [
        str(tmp_path / "p/reference_defaults/slow/classic_head_on_corridor_low__111.html")
    ]
    page = Path(paired["players"][0]).read_text()
    assert (
        page.count('class="pane"') == 2 and "<h2>a: success</h2>" in page and "<h2>slow: timeout</h2>" in page
    )
    assert set(Path(tempfile.gettempdir()).glob("planner_ab_traces_*")) == before
