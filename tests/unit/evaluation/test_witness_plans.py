"""bench/witness_plans.py: the plan family (its driver is the scripted planner), a real run both ways, and refused arguments."""

from __future__ import annotations

import json
import subprocess
import sys
from types import SimpleNamespace

from tests.unit.bench_scripts import BENCH as BENCH_DIR
from tests.unit.bench_scripts import load_bench

BENCH = BENCH_DIR / "witness_plans.py"
NOBODY_YIELDS = ["--override", "ped_speed_tier=typical", "--override", "peds_have_robot_repulsion=false"]


def test_the_family_is_the_direct_drive_every_via_combination_and_every_hold_release() -> None:
    wp = load_bench("witness_plans")
    assert wp.grid("1:2:0.5,3") == [(1.0, 3.0), (1.5, 3.0), (2.0, 3.0)]
    args = SimpleNamespace(via=["0:1:1,0", "5,5:6:1"], hold=["9,9"], release="10:14:2", after=["7,7:8:1"])
    family = wp.plans(args)
    assert len(family) == 1 + 2 * 2 + 3 * 2
    assert family[0] == ((), None, ())
    assert ((0.0, 0.0), (5.0, 6.0)) in [f[0] for f in family]
    assert family[-1] == ((), ((9.0, 9.0), 14.0), ((7.0, 8.0),))
    assert wp.plans(SimpleNamespace(via=[], hold=["9,9"], release="1", after=[]))[-1] == (
        (),
        ((9.0, 9.0), 1.0),
        (),
    )


def test_a_real_run_finds_a_witness_where_the_corridor_is_free_and_none_where_a_walker_blocks_its_mouth() -> (
    None
):
    done = subprocess.run(
        [
            sys.executable,
            str(BENCH),
            "--scenarios",
            "classic_bottleneck_low,classic_bottleneck_medium",
            "--seeds-per-scenario",
            "1",
            *NOBODY_YIELDS,
            "--via",
            "20:21:1,11.5",
            "--workers",
            "2",
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert out["plans"] == 3
    low, medium = out["scenarios"]["classic_bottleneck_low"], out["scenarios"]["classic_bottleneck_medium"]
    assert low["witnessed"] == 1 and 5.0 < low["per_seed"][0]["best"]["arrival_s"] < 50.0
    assert medium["witnessed"] == 0 and medium["per_seed"][0] == {"seed": 131, "witnesses": 0, "best": None}


def test_with_an_evaluations_episodes_only_its_failures_are_tried(tmp_path) -> None:
    rows = [
        ("classic_bottleneck_low", 131, "timeout"),
        ("classic_bottleneck_low", 132, "success"),
        ("classic_bottleneck_medium", 131, "collision_pedestrian"),
        ("classic_doorway_low", 141, "timeout"),
    ]
    episodes = tmp_path / "episodes.jsonl"
    episodes.write_text(
        "".join(json.dumps({"scenario": n, "seed": s, "outcome": o}) + "\n" for n, s, o in rows)
    )
    done = subprocess.run(
        [
            sys.executable,
            str(BENCH),
            "--scenarios",
            "classic_bottleneck_low,classic_bottleneck_medium",
            "--episodes",
            str(episodes),
            *NOBODY_YIELDS,
            "--via",
            "20:21:1,11.5",
            "--workers",
            "2",
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)["scenarios"]
    low, medium = out["classic_bottleneck_low"]["per_seed"], out["classic_bottleneck_medium"]["per_seed"]
    assert [(p["seed"], p["planner_outcome"], p["witnesses"] > 0) for p in low] == [(131, "timeout", True)]
    assert [(p["seed"], p["planner_outcome"], p["witnesses"]) for p in medium] == [
        (131, "collision_pedestrian", 0)
    ]


def test_bad_arguments_are_refused_in_one_line(tmp_path) -> None:
    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, str(BENCH), "--scenarios", "classic_bottleneck_low", *args],
            capture_output=True,
            text=True,
            timeout=300,
        )

    backwards = run("--via", "3:1:1,2")
    assert backwards.returncode != 0 and "'3:1:1': expected START:STOP:STEP" in backwards.stderr
    assert len(backwards.stderr.strip().splitlines()) == 1
    no_y = run("--hold", "3")
    assert no_y.returncode != 0 and "'3': expected X,Y" in no_y.stderr
    huge = run("--via", "0:999:1,0:999:1")
    assert huge.returncode != 0 and "over the 1000000 one run may take" in huge.stderr
    broken = tmp_path / "episodes.jsonl"
    broken.write_text(
        '{"scenario": "classic_bottleneck_low", "seed": 131, "outcome": "timeout"}\n{"seed": 1}\n'
    )
    bad_episodes = run("--episodes", str(broken))
    assert (
        bad_episodes.returncode != 0
        and "expected episode records with scenario, seed and outcome" in bad_episodes.stderr
    )
    missing = run("--episodes", str(tmp_path / "none.jsonl"))
    assert missing.returncode != 0 and "none.jsonl: file does not exist" in missing.stderr
    unknown = subprocess.run(
        [sys.executable, str(BENCH), "--scenarios", "no_such_scenario"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert unknown.returncode != 0 and "no scenario 'no_such_scenario'" in unknown.stderr
