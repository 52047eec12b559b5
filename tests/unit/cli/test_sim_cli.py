"""The simulator-facing CLI commands, run in-process through cli.main.main (exit codes and --json output)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from foresight.cli.main import main

REPO = Path(__file__).resolve().parents[3]
OUR_MATRIX = REPO / "configs" / "scenarios" / "classic_interactions.yaml"


def _json(capsys) -> object:
    return json.loads(capsys.readouterr().out)


def _episode(capsys) -> dict:
    """The one episode of a ``sim run --json`` (the job envelope, as a server job's)."""
    job = json.loads(capsys.readouterr().out)
    assert job["kind"] == "simulate" and job["status"] == "succeeded"
    (episode,) = job["result"]["episodes"]
    return episode


def test_scenarios_list_reference_matrix(reference_matrix_path: Path, capsys) -> None:
    assert main(["scenarios", "list", "--matrix", str(reference_matrix_path), "--json"]) == 0
    rows = _json(capsys)
    assert len(rows) == 23
    trap = next(r for r in rows if r["name"] == "classic_cross_trap_high")
    assert (trap["pedestrians"], trap["horizon"], trap["seeds"]) == (12, 600, [101, 102, 103])


def test_scenarios_list_our_matrix_text(capsys) -> None:
    assert main(["scenarios", "list", "--matrix", str(OUR_MATRIX)]) == 0
    out = capsys.readouterr().out
    assert "33 scenarios" in out and "doorway_high" in out


def test_sim_run_json_and_render(reference_matrix_path: Path, tmp_path: Path, capsys) -> None:
    png = tmp_path / "ep.png"
    args = [
        "sim",
        "run",
        "--matrix",
        str(reference_matrix_path),
        "--scenario",
        "classic_doorway_low",
        "--seed",
        "141",
    ]
    assert main([*args, "--render", str(png), "--json", "--local"]) == 0
    first = _episode(capsys)
    assert first["outcome"] in {"success", "collision_pedestrian", "collision_static", "timeout"}
    assert 0 < first["steps"] <= 500 and first["pedestrians"] == 3
    assert png.stat().st_size > 10_000
    assert main([*args, "--json", "--local"]) == 0
    again = _episode(capsys)
    assert (again["outcome"], again["steps"], again["min_distance"]) == (
        first["outcome"],
        first["steps"],
        first["min_distance"],
    )


def test_sim_run_chooses_the_planner(tmp_path: Path, capsys) -> None:
    args = [
        "sim",
        "run",
        "--local",
        "--json",
        "--matrix",
        str(OUR_MATRIX),
        "--scenario",
        "crossing_low",
        "--seed",
        "1000",
    ]
    assert main(args) == 0
    assert _episode(capsys)["planner"] == "goal"  # the default, as before
    assert main([*args, "--planner", "orca"]) == 0
    orca = _episode(capsys)
    assert (orca["planner"], orca["model_id"]) == ("orca", "none") and orca["steps"] > 0
    assert main([*args, "--planner", "predictive", "--model", "cv"]) == 0
    predictive = _episode(capsys)
    assert (predictive["planner"], predictive["model_id"]) == ("predictive", "cv")
    assert main([*args, "--planner", "orcaa"]) == 1
    err = capsys.readouterr().err
    assert "unknown planner 'orcaa' (installed: predictive, orca" in err and "did you mean 'orca'?" in err


def test_sim_run_unknown_scenario_is_one_line_error(reference_matrix_path: Path, capsys) -> None:
    rc = main(
        ["sim", "run", "--matrix", str(reference_matrix_path), "--scenario", "nope", "--seed", "1", "--local"]
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and len(err) == 1 and "nope" in err[0]


def test_corpus_matrix_lists_and_runs_and_a_non_matrix_is_one_line(
    corpus_dir: Path, tmp_path: Path, capsys
) -> None:
    scen = corpus_dir / "configs" / "scenarios"
    event = scen / "single" / "event_disruption_public_exit.yaml"
    assert main(["scenarios", "list", "--matrix", str(event), "--json"]) == 0
    (row,) = _json(capsys)
    assert row["name"] == "event_disruption_public_exit_blocked_path_v1" and row["pedestrians"] > 4
    png = tmp_path / "event.png"
    args = [
        "sim",
        "run",
        "--local",
        "--json",
        "--matrix",
        str(event),
        "--scenario",
        row["name"],
        "--seed",
        "4759",
    ]
    assert main([*args, "--render", str(png)]) == 0
    assert _episode(capsys)["outcome"] in {"success", "collision_pedestrian", "collision_static", "timeout"}
    assert png.stat().st_size > 10_000
    contract = scen / "contracts" / "issue_2164_amv_cross_trap_contracts.yaml"
    assert main(["scenarios", "list", "--matrix", str(contract)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].endswith(
        f"{contract}: not a scenario matrix (it is a scenario contract set)"
    )


def test_missing_matrix_names_the_file(capsys) -> None:
    assert main(["scenarios", "list", "--matrix", "/no/such/matrix.yaml"]) == 1
    assert "/no/such/matrix.yaml" in capsys.readouterr().err


def test_maps_convert_round_trip(reference_dir: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "doorway.yaml"
    svg = reference_dir / "maps" / "svg_maps" / "classic_doorway.svg"
    assert main(["maps", "convert", str(svg), "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["maps", "show", str(out), "--json"]) == 0
    info = _json(capsys)
    assert (info["width"], info["height"], info["ped_routes"]) == (44.0, 28.0, [35.78])


def test_maps_rehash_updates_a_stale_registry(tmp_path: Path, capsys) -> None:
    root = tmp_path / "maps"
    shutil.copytree(REPO / "configs" / "maps", root)
    edited = root / "doorway.yaml"
    edited.write_text(edited.read_text() + "\n# edited\n")
    assert main(["maps", "rehash", str(root / "registry.yaml"), "--check", "--json"]) == 1
    assert list(_json(capsys)) == ["doorway"]
    assert main(["maps", "rehash", str(root / "registry.yaml")]) == 0
    capsys.readouterr()
    assert main(["maps", "rehash", str(root / "registry.yaml"), "--check"]) == 0


def test_scenarios_check_finds_episodes_lost_at_spawn(shared_dir: Path, capsys) -> None:
    """The stress suite passes; under version 1's spawn rule (0.5 m) some standing robots are walked into: exit 1."""
    stress = str(REPO / "configs" / "scenarios" / "stress.yaml")
    assert main(["scenarios", "check", "--matrix", stress, "--seeds-per-scenario", "3", "--json"]) == 0
    assert _json(capsys)["lost"] == []
    args = [
        "scenarios",
        "check",
        "--matrix",
        stress,
        "--seeds-per-scenario",
        "3",
        "--override",
        "robot_spawn_clearance=0.5",
    ]
    assert main([*args, "--json"]) == 1
    report = _json(capsys)
    assert report["episodes"] == 22 * 3 + 36 and report["lost"]
    assert all(
        c["time_s"] <= 1.5
        and c["scenario"]
        in {
            "head_on_corridor_nr30",
            "head_on_corridor_nr100",
            "bottleneck_nr30",
            "bottleneck_nr100",
            "t_intersection_nr30",
            "t_intersection_nr100",
            "merging_nr30",
        }
        for c in report["lost"]
    )
    assert main(args) == 1 and "walked into (lost before a planner can act)" in capsys.readouterr().out


def test_scenarios_check_refuses_a_bad_duration(capsys) -> None:
    assert main(["scenarios", "check", "--matrix", str(OUR_MATRIX), "--seconds", "0"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--seconds" in err[0]


def test_scenarios_reachable_names_the_episodes_no_robot_could_solve(
    shared_dir: Path, tmp_path: Path, capsys
) -> None:
    """Nobody yields at typical speed: the high-density bottleneck cannot be crossed in time, the medium one can;
    an evaluation's outcomes are scored on the reachable episodes only."""
    classic = str(shared_dir / "reference/robot_sf/configs/scenarios/classic_interactions.yaml")
    args = [
        "scenarios",
        "reachable",
        "--matrix",
        classic,
        "--override",
        "ped_speed_tier=typical",
        "--override",
        "peds_have_robot_repulsion=false",
        "--seeds-per-scenario",
        "1",
        "--scenarios",
        "classic_bottleneck_high,classic_bottleneck_medium",
    ]
    episodes = tmp_path / "episodes.jsonl"
    episodes.write_text(
        json.dumps({"scenario": "classic_bottleneck_medium", "seed": 131, "outcome": "success"})
        + "\n"
        + json.dumps({"scenario": "classic_bottleneck_high", "seed": 131, "outcome": "timeout"})
        + "\n"
    )
    assert main([*args, "--episodes", str(episodes), "--json"]) == 0
    report = _json(capsys)
    assert report["episodes"] == 2 and report["reachable"] == 1 and not report["approximate"]
    assert [(u["scenario"], u["seed"]) for u in report["unreachable"]] == [("classic_bottleneck_high", 131)]
    assert report["success_on_reachable"] == {"successes": 1, "episodes": 1, "rate": 1.0}
    medium = report["verdicts"][1]
    assert (
        medium["scenario"] == "classic_bottleneck_medium"
        and medium["reachable"]
        and 100 < medium["first_step"] < 500
    )
    assert main(args) == 0 and "classic_bottleneck_high seed 131: goal unreachable" in capsys.readouterr().out


def test_scenarios_reachable_refuses_an_evaluation_without_the_episodes(
    shared_dir: Path, tmp_path: Path, capsys
) -> None:
    classic = str(shared_dir / "reference/robot_sf/configs/scenarios/classic_interactions.yaml")
    other = tmp_path / "episodes.jsonl"
    other.write_text(
        json.dumps({"scenario": "classic_doorway_low", "seed": 141, "outcome": "success"}) + "\n"
    )
    args = [
        "scenarios",
        "reachable",
        "--matrix",
        classic,
        "--scenarios",
        "classic_bottleneck_medium",
        "--seeds-per-scenario",
        "1",
        "--episodes",
        str(other),
    ]
    assert main(args) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "episodes.jsonl" in err[0] and "classic_bottleneck_medium 131" in err[0]
    other.write_text("not json\n")
    assert main(args) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "expected episode records" in err[0]


def test_scenarios_reachable_draws_each_verdict(shared_dir: Path, tmp_path: Path, capsys) -> None:
    """--pictures DIR: one PNG per episode, listed in the report; the map under it is the scenario's."""
    classic = str(shared_dir / "reference/robot_sf/configs/scenarios/classic_interactions.yaml")
    out = tmp_path / "pictures"
    args = [
        "scenarios",
        "reachable",
        "--matrix",
        classic,
        "--override",
        "ped_speed_tier=typical",
        "--override",
        "peds_have_robot_repulsion=false",
        "--seeds-per-scenario",
        "1",
        "--scenarios",
        "classic_bottleneck_high,classic_bottleneck_medium",
        "--pictures",
        str(out),
        "--json",
    ]
    assert main(args) == 0
    report = _json(capsys)
    assert report["pictures"] == [
        str(out / "reach_classic_bottleneck_high_131.png"),
        str(out / "reach_classic_bottleneck_medium_131.png"),
    ]
    for p in report["pictures"]:
        data = Path(p).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    assert report["unreachable"][0]["picture"] == report["pictures"][0]
    taken = tmp_path / "a_file"
    taken.write_text("x")
    assert main([*args[:-3], "--pictures", str(taken)]) != 0  # a file where the folder should be: one line
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "a_file" in err[0] and "expected a folder" in err[0]
    assert taken.read_text() == "x"
