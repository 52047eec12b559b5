"""Stage commands in server mode (the default) without a server: what is refused before anything is sent,
and the one line printed when no server answers. (Submissions to a real server: tests/integration/test_cli_remote.py.)"""

from __future__ import annotations

import json
import socket
from pathlib import Path

import pytest

from foresight import local
from foresight.cli import stage
from foresight.cli.main import main
from foresight.core.errors import ConfigError
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT


@pytest.fixture
def nowhere() -> str:
    """A URL where no server listens (a port just released)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return f"http://127.0.0.1:{port}"


def _one_line_error(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("foresight: error:"), err
    return err[0]


@pytest.mark.parametrize(
    "argv",
    [
        ["collect", "--scenarios", "crossing_low", "--seeds-per-scenario", "1"],
        ["train", "--dataset", "some-dataset-id", "--epochs", "1"],
        [
            "evaluate",
            "--matrix",
            "scenarios/classic_interactions.yaml",
            "--planner",
            "goal",
            "--scenarios",
            "crossing_low",
        ],
        ["dataset", "import-ethucy", "--root", "ethucy", "--fold", "zara1"],
        [
            "sim",
            "run",
            "--matrix",
            "scenarios/classic_interactions.yaml",
            "--scenario",
            "crossing_low",
            "--seed",
            "1",
        ],
        ["pipeline", "run", "-f", "configs/pipelines/smoke.yaml"],
    ],
)
def test_unreachable_server_is_one_line_naming_up_and_local(argv: list[str], nowhere: str, capsys) -> None:  # noqa: ANN001
    assert main([*argv, "--url", nowhere]) == 1
    line = _one_line_error(capsys)
    assert f"cannot reach the server at {nowhere}" in line and "foresight up" in line and "--local" in line


def test_local_files_where_ids_are_needed_are_refused(tmp_path: Path, nowhere: str, capsys) -> None:  # noqa: ANN001
    npz, ckpt, matrix = tmp_path / "d.npz", tmp_path / "m.pt", tmp_path / "matrix.yaml"
    for f in (npz, ckpt, matrix):
        f.write_text("x")
    cases = [
        (["train", "--dataset", str(npz)], "--dataset", "dataset id"),
        (["mix", "--base", "a", "--hardcase", str(npz)], "--hardcase", "dataset id"),
        (["predict-eval", "--model", str(ckpt), "--dataset", "abc"], "--model", "model id"),
        (["predict-eval", "--model", "cv", "--ethucy", str(tmp_path)], "--ethucy", "--ethucy NAME"),
        (
            ["dataset", "import-ethucy", "--ethucy", str(tmp_path), "--fold", "zara1"],
            "--ethucy",
            "--root NAME",
        ),
        (["evaluate", "--matrix", str(matrix), "--planner", "goal"], "--matrix", "bundles upload"),
        (
            [
                "campaign",
                "--matrix",
                "scenarios/classic_interactions.yaml",
                "--seeds",
                "seeds/x.yaml",
                "--grid",
                "grids/y.yaml",
                "--checkpoints",
                str(ckpt),
            ],
            "--checkpoints",
            "model id",
        ),
        (["train", "--dataset", "abc", "--out", str(tmp_path)], "--out", "--local runs only"),
        (
            [
                "evaluate",
                "--matrix",
                "scenarios/classic_interactions.yaml",
                "--planner",
                "goal",
                "--workers",
                "2",
            ],
            "--workers",
            "--local runs only",
        ),
    ]
    for argv, flag, hint in cases:
        assert main([*argv, "--url", nowhere]) == 1, argv
        line = _one_line_error(capsys)
        assert f"item {flag!r}" in line and hint in line and "cannot reach" not in line, line
        if flag not in ("--out", "--workers"):
            assert "--local" in line, line


def test_bad_values_fail_before_submission(nowhere: str, capsys) -> None:  # noqa: ANN001
    assert main(["collect", "--seeds-per-scenario", "0", "--url", nowhere]) == 1
    assert "seeds_per_scenario" in _one_line_error(capsys)
    assert main(["dataset", "import-ethucy", "--root", "../etc", "--fold", "zara1", "--url", nowhere]) == 1
    assert "'root'" in _one_line_error(capsys)
    assert main(["evaluate", "--matrix", "/etc/matrix.yaml", "--planner", "goal", "--url", nowhere]) == 1
    assert "relative to its bundle root" in _one_line_error(capsys)


def test_bundle_names() -> None:
    matrix = BUILTIN_CONFIG_ROOT / "scenarios" / "classic_interactions.yaml"
    assert stage.bundle_names(None, {"--matrix": str(matrix), "--seeds": None}) == (
        "builtin",
        {"--matrix": "scenarios/classic_interactions.yaml", "--seeds": None},
    )
    assert stage.bundle_names(None, {"--matrix": "scenarios/x.yaml"}) == (
        "builtin",
        {"--matrix": "scenarios/x.yaml"},
    )
    assert stage.bundle_names("mine", {"--matrix": "m.yaml"}) == ("mine", {"--matrix": "m.yaml"})
    with pytest.raises(ConfigError, match="outside the project's configs"):
        stage.bundle_names(None, {"--matrix": __file__})


def test_the_local_and_server_specs_are_one_model() -> None:
    """Both modes validate the job kind's spec; --local runs the core config a worker would build from it."""
    from foresight.core.jobs.kinds import KINDS
    from foresight.core.training.collect import CollectConfig

    spec = local.spec("collect", {"scenarios": ["crossing_low"], "seeds_per_scenario": 2, "max_steps": None})
    assert isinstance(spec, KINDS["collect"].spec) and spec.kind == "collect"
    config = local.config_of(spec)
    assert type(config) is CollectConfig and config.model_dump() == spec.model_dump(exclude={"kind"})
    with pytest.raises(ConfigError, match="seeds_per_scenario"):
        local.spec("collect", {"seeds_per_scenario": -1})


def test_an_in_process_failure_prints_the_failed_job_with_json(capsys: pytest.CaptureFixture[str]) -> None:
    """With --json a --local run that fails prints the failed job (status, error; the server's job keys), then
    its one error line, as a failed server job does."""
    argv = [
        "sim",
        "run",
        "--local",
        "--json",
        "--matrix",
        str(BUILTIN_CONFIG_ROOT / "scenarios" / "classic_interactions.yaml"),
        "--scenario",
        "crossing_lo",
        "--seed",
        "1000",
    ]
    assert main(argv) == 1
    out = capsys.readouterr().out
    job = json.loads(out)
    assert (job["id"], job["kind"], job["status"], job["result"], job["verdict"]) == (
        None,
        "simulate",
        "failed",
        None,
        None,
    )
    assert (
        job["error"]["type"] == "NotFoundError" and "did you mean 'crossing_low'" in job["error"]["message"]
    )
