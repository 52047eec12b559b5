"""`--json` has one shape whether a stage command runs on the server or in-process (``--local``): the job as
``GET /v1/jobs/ID`` returns it, result nested. Each command runs both ways against a real `foresight up`, at smoke
size, and the two documents are compared key by key (and validated as the API's job model)."""

from __future__ import annotations

import json
from pathlib import Path

from foresight.api.schemas import JobPublic

from .service import Service

MATRIX = "configs/scenarios/classic_interactions.yaml"
SMOKE = ["--scenarios", "crossing_low", "--seeds-per-scenario", "1", "--max-steps", "20"]


def _both(
    service: Service, name: str, server: list[str], local: list[str] | None = None, out: bool = True
) -> tuple[dict, dict]:
    """The command's --json document from the server and in-process (``local``: its arguments there, when a
    server id becomes a file; ``out``: the command takes --out), after checking both exit the same way."""
    remote = service.cli(*server, "--json", check=False)
    folder = ["--out", str(service.tmp / "local" / name)] if out else []
    here = service.cli(*(local or server), "--json", "--local", *folder, check=False)
    assert remote.returncode == here.returncode and remote.returncode in (0, 2), (remote.stderr, here.stderr)
    return json.loads(remote.stdout), json.loads(here.stdout)


def _same_shape(remote: dict, here: dict) -> None:
    assert set(remote) == set(here), set(remote) ^ set(here)
    JobPublic.model_validate(remote)
    JobPublic.model_validate({**here, "id": "-"})  # the API's model, but for the id an in-process run has not
    same = ("kind", "status", "verdict")
    assert [here[k] for k in same] == [remote[k] for k in same]
    assert remote["id"] and here["id"] is None and here["worker"] == "local"
    assert set(remote["spec"]) == set(here["spec"]), set(remote["spec"]) ^ set(here["spec"])
    assert isinstance(remote["result"], dict) and set(remote["result"]) == set(here["result"])
    assert {tuple(sorted(a)) for a in remote["artifacts"] + here["artifacts"]} <= {
        ("name", "sha256", "size", "url")
    }
    assert all(a["url"].startswith("file:///") and Path(a["url"][7:]).is_file() for a in here["artifacts"])


def test_stage_commands_print_one_json_shape_in_both_modes(service: Service, shared_dir: Path) -> None:
    service.env["FORESIGHT_DATA_ROOTS"] = f"ethucy={shared_dir / 'reference' / 'ethucy'}"
    service.serve("up")

    remote, here = _both(
        service,
        "evaluate",
        ["evaluate", "--matrix", MATRIX, "--planner", "goal", *SMOKE, "--min-success", "0"],
    )
    _same_shape(remote, here)
    assert here["result"]["episodes"] == remote["result"]["episodes"] == 1
    # the same files (and, in-process, the player pages the server's dashboard draws on request)
    assert {a["name"] for a in remote["artifacts"]} <= {a["name"] for a in here["artifacts"]}
    assert here["spec"] == remote["spec"]  # one command line, one job

    # `submit --wait --json` prints the same document as the stage command does
    spec = service.tmp / "evaluate.yaml"
    spec.write_text(
        "matrix: scenarios/classic_interactions.yaml\nplanner: {name: goal}\nscenarios: [crossing_low]\n"
        "seeds_per_scenario: 1\nmax_steps: 20\ngate: {min_success_rate: 0}\n"
    )
    submitted = json.loads(service.cli("submit", "evaluate", "-f", str(spec), "--wait", "--json").stdout)
    _same_shape(submitted, here)

    _same_shape(
        *_both(
            service,
            "diagnose",
            [
                "diagnose",
                "--matrix",
                MATRIX,
                "--planner",
                "goal",
                "--seeds",
                "configs/seeds/classic_eval_hard_smoke.yaml",
                "--max-steps",
                "20",
                "--no-render",
            ],
        )
    )
    remote, here = _both(
        service,
        "sim",
        [
            "sim",
            "run",
            "--matrix",
            MATRIX,
            "--scenario",
            "crossing_low",
            "--seed",
            "1000",
            "--render",
            str(service.tmp / "ep.png"),
        ],
        out=False,
    )
    _same_shape(remote, here)
    assert here["result"]["episodes"][0].keys() == remote["result"]["episodes"][0].keys()

    remote, here = _both(
        service,
        "collect",
        [
            "collect",
            "--scenarios",
            "crossing_low,crossing_medium",
            "--seeds-per-scenario",
            "2",
            "--max-steps",
            "80",
        ],
    )
    _same_shape(remote, here)
    dataset = service.tmp / "local" / "collect" / here["result"]["dataset"]
    assert dataset.is_file() and dataset.as_uri() in {a["url"] for a in here["artifacts"]}
    _same_shape(
        *_both(
            service,
            "mix",
            ["mix", "--base", remote["id"], "--hardcase", remote["id"]],
            ["mix", "--base", str(dataset), "--hardcase", str(dataset)],
        )
    )
    train = ["--config", "configs/training/smoke.yaml", "--epochs", "1"]
    _same_shape(
        *_both(
            service,
            "train",
            ["train", "--dataset", remote["id"], *train],
            ["train", "--dataset", str(dataset), *train],
        )
    )
    _same_shape(
        *_both(
            service,
            "predict-eval",
            ["predict-eval", "--model", "cv", "--ethucy", "ethucy", "--fold", "zara1"],
        )
    )
    _same_shape(
        *_both(
            service,
            "import",
            ["dataset", "import-ethucy", "--root", "ethucy", "--fold", "zara1"],
            [
                "dataset",
                "import-ethucy",
                "--root",
                "ethucy",
                "--fold",
                "zara1",
                "--output",
                str(service.tmp / "zara1.npz"),
            ],
            out=False,
        )
    )
    _same_shape(*_both(service, "check", ["planners", "check", "goal", "--steps", "5"], out=False))
