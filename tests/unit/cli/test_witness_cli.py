"""`foresight scenarios witness` on a real evaluation's failures: which of them a robot with these limits could
solve, the witness watched beside the planner's run, and the witness replayed as a planner by `foresight sim run`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from foresight.cli.main import main


def _json(capsys) -> dict:
    return json.loads(capsys.readouterr().out)


def test_an_evaluations_failures_get_witnesses_and_players(
    reference_matrix_path: Path, tmp_path: Path, capsys
) -> None:
    matrix = str(reference_matrix_path)
    run = tmp_path / "goal"  # (exit 2 below: the goal-seeking robot fails the evaluation's quality gate)
    assert main(
        [
            "evaluate",
            "--local",
            "--matrix",
            matrix,
            "--planner",
            "goal",
            "--scenarios",
            "classic_doorway_medium",
            "--seeds-per-scenario",
            "3",
            "--override",
            "ped_speed_tier=typical",
            "--out",
            str(run),
            "--json",
        ]
    ) in (0, 2)
    capsys.readouterr()
    outcomes = {
        json.loads(line)["seed"]: json.loads(line)["outcome"] for line in (run / "episodes.jsonl").open()
    }
    failed = sorted(seed for seed, outcome in outcomes.items() if outcome != "success")
    assert failed  # the goal-seeking robot walks into the stream at least once
    players = tmp_path / "players"
    args = [
        "scenarios",
        "witness",
        "--matrix",
        matrix,
        "--episodes",
        str(run / "episodes.jsonl"),
        "--max-plans",
        "80",
    ]
    assert main([*args, "--players", str(players), "--workers", "2", "--json"]) == 0
    report = _json(capsys)
    # the evaluation's own conditions (its evaluation.json), only its failed episodes
    assert (
        report["overrides"] == {"simulation_config": {"ped_speed_tier": "typical"}} and report["failed_only"]
    )
    assert [e["seed"] for e in report["episodes"]] == failed
    assert [e["planner_outcome"] for e in report["episodes"]] == [outcomes[s] for s in failed]
    witnessed = [e for e in report["episodes"] if e["plan"] is not None]
    assert report["witnessed"] == len(witnessed) >= 1
    first = witnessed[0]
    assert (
        first["player"] == f"classic_doorway_medium__{first['seed']}.html"
    )  # in the job's folder: --players DIR
    page = players / first["player"]
    html = page.read_text()
    report = (
        players / "report.html"
    ).read_text()  # the job's report: every episode, and a link to each player
    assert (
        "Witnesses: " in report and f'href="{first["player"]}"' in report and "closest pedestrian" in report
    )
    assert (
        f"planner: {first['planner_outcome']}" in html
        and "witness: " in html
        and html.count('<script type="application/json"') == 2  # two embedded traces
    )
    # the witness is a planner like any other: `foresight evaluate` replays it under the same conditions, and it arrives
    replay = tmp_path / "replay"
    assert main(
        [
            "evaluate",
            "--local",
            "--matrix",
            matrix,
            "--planner",
            "scripted",
            "--planner-config",
            json.dumps(first["plan"]),
            "--scenarios",
            "classic_doorway_medium",
            "--seeds-per-scenario",
            "3",
            "--override",
            "ped_speed_tier=typical",
            "--out",
            str(replay),
            "--json",
        ]
    ) in (0, 2)
    capsys.readouterr()
    again = {json.loads(line)["seed"]: json.loads(line) for line in (replay / "episodes.jsonl").open()}[
        first["seed"]
    ]
    assert again["outcome"] == "success" and again["steps"] * 0.1 == pytest.approx(first["arrival_s"])
    assert (
        main([*args, "--price"]) != 0
    )  # only the predictive planner rides along, not this evaluation's goal robot
    err = capsys.readouterr().err.strip().splitlines()
    assert (
        len(err) == 1 and "priced by the predictive planner riding along; the evaluation ran 'goal'" in err[0]
    )
    assert (
        main([*args, "--override", "ped_speed_tier=typical", "--min-clearance", "0.2"]) == 0
    )  # as text, with room
    out = capsys.readouterr().out
    assert "witnessed solvable by a robot with these limits, keeping 0.2 m from every pedestrian" in out
    assert "arrives at" in out and "m from the closest pedestrian" in out


def test_the_predictive_planner_prices_each_witness(reference_matrix_path: Path, capsys) -> None:
    args = [
        "scenarios",
        "witness",
        "--matrix",
        str(reference_matrix_path),
        "--scenarios",
        "classic_head_on_corridor_low",
        "--seeds-per-scenario",
        "1",
        "--override",
        "ped_speed_tier=typical",
        "--max-plans",
        "5",
        "--price",
    ]
    assert main([*args, "--json"]) == 0
    (row,) = _json(capsys)["episodes"]
    assert row["plan"] is not None and row["clearance_m"] < 0.3  # the route as is passes the walkers close
    priced = row["priced"]
    assert priced["planner"].startswith("predictive ") and priced["decisions"]
    assert any(
        d["witness_cost"] > d["chosen_cost"] and "collision" in d["dearer"] for d in priced["decisions"]
    )
    assert main(args) == 0
    out = capsys.readouterr().out
    assert (
        "    priced: the planner's own cost would have left the witness's course while it drives, at " in out
    )


def test_bad_arguments_are_refused_in_one_line(reference_matrix_path: Path, tmp_path: Path, capsys) -> None:
    base = [
        "scenarios",
        "witness",
        "--matrix",
        str(reference_matrix_path),
        "--scenarios",
        "classic_doorway_low",
    ]
    for extra, words in (
        (["--players", str(tmp_path)], "give its --episodes"),
        (["--max-plans", "0"], "expected 1 to 20000 plans"),
        (["--workers", "0"], "expected at least 1 worker"),
        (["--min-clearance", "nan"], "expected 0 to 2 m"),
        (["--episodes", str(tmp_path / "none.jsonl")], "file does not exist"),
    ):
        assert main([*base, *extra]) != 0
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0], (extra, err)
