"""Every ```bash block of README.md and of the documentation pages (docs/) is either run here as written (from a
scratch folder that looks like the repository root: `.venv`, `configs` and `../shared` resolve; the quickstart from
an empty folder), run by another test, a copy of a block that is run, or on the explicit exclusion list below with its
reason; an excluded block's `foresight` commands must still exist with every flag they use. A new block that is none
of these fails `test_every_bash_block_is_run_or_excluded`, so the pages cannot drift.

The service sections run against a real `foresight up` (README's quickstart line, on a free port) with a temporary
HOME: the token and `server.json` land in `~/.local/share/foresight` as the pages say, and the placeholders (JOB_ID,
EVAL_ID, DATASET_ID, CAMPAIGN_ID, ...) become the ids the earlier commands printed. The `foresight ...` and `bench/...`
commands the pages quote in their prose must exist with the options they show (checked against the CLI's parser and
the scripts' declared flags)."""

from __future__ import annotations

import argparse
import itertools
import json
import os
import re
import shlex
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import httpx
import pytest
import yaml

from tests.conftest import shared_root
from tests.e2e.service import REPO, free_port, wait_job
from tests.readme import DOCS, blocks, commands, page_name, pages, section_blocks

pytestmark = pytest.mark.slow

VENV_BIN = Path(sys.executable).parent


@dataclass(frozen=True)
class Elsewhere:
    test: str  #: the test file that runs the block as written


@dataclass(frozen=True)
class Excluded:
    reason: str


@dataclass(frozen=True)
class Copy:
    of: tuple[str, str, int]  #: the block (page, section, index) it repeats word for word, which is run


RUN_HERE = "run here"
QUICKSTART = ("README.md", "Quickstart (five minutes, any folder)")
SERVICE = DOCS / "service.md"
PIP = "installs from a package index; tests/e2e/test_wheel.py installs the built wheel (the pinned torch and the "
PIP += "extras are checked)"
MAKE = "full size: `make demo` is the quickstart pipeline, `make test` the whole suite (the Makefile targets are checked)"

#: every bash block of README.md and docs/, by (page, section, index among the section's blocks): run here,
#: elsewhere, a copy of one that is, or why not
BASH_BLOCKS: dict[tuple[str, str, int], str | Elsewhere | Excluded | Copy] = {
    ("README.md", "Install", 0): Excluded(PIP),
    ("README.md", "Install", 1): Excluded(MAKE),
    (*QUICKSTART, 0): RUN_HERE,
    (*QUICKSTART, 1): RUN_HERE,
    ("docs/getting-started.md", "Install", 0): Excluded(PIP),
    ("docs/getting-started.md", "Install", 1): Excluded(MAKE),
    ("docs/getting-started.md", "Quickstart", 0): Copy((*QUICKSTART, 0)),
    ("docs/getting-started.md", "Quickstart", 1): Copy((*QUICKSTART, 1)),
    ("docs/tutorials/simulator.md", "The simulator", 0): RUN_HERE,
    ("docs/tutorials/simulator.md", "Importing the reference system's files", 0): RUN_HERE,
    ("docs/service.md", "The service", 0): RUN_HERE,
    ("docs/service.md", "The service", 1): RUN_HERE,
    ("docs/service.md", "Finding and organising runs", 0): Elsewhere("tests/e2e/test_finding_runs.py"),
    ("docs/tutorials/scaling-out.md", "Scaling out on Ray", 0): Excluded(
        "a multi-node Ray cluster (`ray start` on the head and on every machine)"),
    ("docs/tutorials/scaling-out.md", "Scaling out on Ray", 1): Excluded(
        "a SLURM batch script (sbatch, srun, scontrol on 16 nodes)"),
    ("docs/tutorials/own-planner.md", "Evaluate your own planner", 1): Elsewhere(
        "tests/unit/library/test_readme_routes.py"),
    ("docs/tutorials/own-planner.md", "Evaluate your own planner", 2): Elsewhere(
        "tests/unit/library/test_readme_routes.py"),
    ("docs/tutorials/own-predictor.md", "Bring your own predictor and data", 0): Excluded(
        "needs your own recordings folder (and minutes for every ETH/UCY fold); tests/unit/predict/"
        "test_scene_import.py and test_predictor_plugins.py run each command's route on ETH/UCY scene files"),
    ("docs/tutorials/sb3.md", "1. Install", 0): Excluded(PIP),
    ("docs/tutorials/sb3.md", "3. Evaluate in-process", 0): Elsewhere("tests/integration/test_sb3_tutorial.py"),
    ("docs/tutorials/sb3.md", "4. Evaluate on the server", 0): Elsewhere("tests/integration/test_sb3_tutorial.py"),
}  # fmt: skip

#: the excluded blocks' shell words that are not ours to check (SLURM and shell syntax of the batch script)
NOT_OURS = {"srun", "sleep", "for", "done", "scontrol"}


def _bash_blocks() -> dict[tuple[str, str, int], str]:
    """Every bash block of every page, by (page, section, index)."""
    return {(page_name(p), *b.key): b.code for p in pages() for b in blocks("bash", p)}


def test_every_bash_block_is_run_or_excluded() -> None:
    found = _bash_blocks()
    assert found.keys() - BASH_BLOCKS.keys() == set(), (
        "bash blocks neither run by a test nor excluded (add them)"
    )
    assert BASH_BLOCKS.keys() - found.keys() == set(), "the pages lost these bash blocks (update BASH_BLOCKS)"
    for key, how in BASH_BLOCKS.items():
        if isinstance(how, Elsewhere):
            assert key[1] in (REPO / how.test).read_text(), f"{how.test} does not read {key[0]}'s {key[1]!r}"
        if isinstance(how, Copy):
            assert BASH_BLOCKS[how.of] == RUN_HERE and found[key] == found[how.of], (
                f"{key} differs from {how.of}"
            )


def _help(argv: list[str]) -> str:
    proc = subprocess.run([*argv, "--help"], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert proc.returncode == 0, f"{' '.join(argv)} --help: {proc.stderr[-2000:]}"
    return proc.stdout


def _check_foresight(words: list[str]) -> None:
    """`foresight SUB... --help` exists and lists every --flag the README line uses."""
    path = list(itertools.takewhile(lambda w: not w.startswith("-"), words[1:]))
    flags = {w.split("=", 1)[0] for w in words if w.startswith("--")}
    for n in range(len(path), 0, -1):  # the longest command path that has a help (the rest are positionals)
        proc = subprocess.run(
            [str(VENV_BIN / "foresight"), *path[:n], "--help"], capture_output=True, text=True, timeout=120
        )
        if proc.returncode == 0:
            missing = [f for f in flags if not re.search(rf"{re.escape(f)}\b", proc.stdout)]
            assert not missing, (
                f"`foresight {' '.join(path[:n])}` has no {missing} (README: {' '.join(words)})"
            )
            return
    raise AssertionError(f"no such command: {' '.join(words)}")


@pytest.mark.parametrize("key", [k for k, how in BASH_BLOCKS.items() if isinstance(how, Excluded)], ids=str)
def test_excluded_blocks_commands_and_flags_exist(key: tuple[str, str, int]) -> None:
    code = _bash_blocks()[key]
    makefile, pyproject = (REPO / "Makefile").read_text(), (REPO / "pyproject.toml").read_text()
    checked = 0
    for line in commands(code):
        if re.match(r"\w+=\(", line):  # a shell array of the batch script
            continue
        words = shlex.split(line, comments=True)
        while words and re.fullmatch(r"\w+=.*", words[0]):  # environment assignments
            words = words[1:]
        if not words or words[0] in NOT_OURS:
            continue
        if (
            "ray" in words and words[words.index("ray") + 1] == "start"
        ):  # also inside `srun ... ray start ...`
            ray = words[words.index("ray") :]
            ray_help = _help([str(VENV_BIN / "ray"), "start"])
            missing = [w for w in ray if w.startswith("--") and w.split("=", 1)[0] not in ray_help]
            assert not missing, f"`ray start` has no {missing}"
        elif Path(words[0]).name == "foresight":
            _check_foresight(words)
        elif words[0] == "make":
            assert re.search(rf"^{words[1]}:", makefile, flags=re.M), f"Makefile has no target {words[1]}"
        elif words[:2] == ["pip", "install"]:
            pin = re.fullmatch(r"torch==(.+)", words[2])
            if pin:
                assert f"torch=={pin.group(1)}" in makefile, "README's torch pin differs from the Makefile's"
            else:
                extras = re.fullmatch(r"foresight\[(.+)\]", words[2])
                assert extras, f"unexpected pip install in README: {line}"
                for extra in extras.group(1).split(","):
                    assert re.search(rf"^{extra} = \[", pyproject, flags=re.M), (
                        f"pyproject.toml has no extra {extra}"
                    )
        else:
            raise AssertionError(f"README's excluded block {key} runs {words[0]!r}: check it here or list it")
        checked += 1
    assert checked, f"nothing checked in {key}"


# ---------------------------------------------------------------- running blocks as written


@pytest.fixture(scope="module")
def scratch(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder standing in for the repository root (`.venv`, `configs` linked; `../shared` beside it), so that
    what the commands write (maps, reports, renders) stays out of the checkout."""
    root = tmp_path_factory.mktemp("readme")
    (root / "shared").symlink_to(shared_root())
    work = root / "repo"
    work.mkdir()
    for name in (".venv", "configs", "examples"):
        (work / name).symlink_to(REPO / name)
    (root / "home").mkdir()
    return work


def _env(scratch: Path, **extra: str) -> dict[str, str]:
    """A user's shell: the scratch HOME (so ~/.local/share/foresight is the data folder), nothing of the tests'."""
    return {
        "PATH": f"{VENV_BIN}:/usr/bin:/bin",
        "HOME": str(scratch.parent / "home"),
        "LANG": "C.UTF-8",
        "FORESIGHT_SHARED": str(shared_root()),
        **extra,
    }


def _run(cmd: str, scratch: Path, prelude: str = "", ok: tuple[int, ...] = (0,), **env: str) -> str:
    start = time.monotonic()
    proc = subprocess.run(
        ["bash", "-e", "-o", "pipefail", "-c", f"{prelude}\n{cmd}"],
        cwd=scratch,
        env=_env(scratch, **env),
        capture_output=True,
        text=True,
        timeout=300,
    )
    print(f"{time.monotonic() - start:5.1f} s  {cmd[:100]}")  # shown with -s: where the test's time goes
    assert proc.returncode in ok, f"README command failed ({proc.returncode}): {cmd}\n{proc.stderr[-3000:]}"
    return proc.stdout


def test_simulator_section_runs_as_written(scratch: Path, shared_dir: Path) -> None:
    listing, check, reachable, witness, episode, demo = commands(
        section_blocks("The simulator", "bash", DOCS / "tutorials" / "simulator.md")[0].code
    )
    assert "crossing_low" in _run(listing, scratch)
    report = json.loads(_run(check, scratch))
    assert report["episodes"] == 256 and report["lost"] == [], report
    verdict = json.loads(
        _run(reachable, scratch)
    )  # nobody yields: the crowded corridor cannot be crossed in time
    assert verdict["episodes"] == 2 and verdict["reachable"] == 0 and not verdict["approximate"], verdict
    assert [Path(p).name for p in verdict["pictures"]] == [
        "reach_classic_bottleneck_high_131.png",
        "reach_classic_bottleneck_high_132.png",
    ], verdict
    assert all((scratch / p).stat().st_size > 0 for p in verdict["pictures"])
    found = json.loads(
        _run(witness, scratch)
    )  # typical speed: waiting for a gap in the door's stream solves 142
    assert [(e["seed"], e["plan"] is not None) for e in found["episodes"]] == [(141, False), (142, True)], (
        found
    )
    assert found["episodes"][1]["plan"]["hold"] and 0 < found["episodes"][1]["arrival_s"] < 50, found
    (record,) = json.loads(_run(episode, scratch))["result"]["episodes"]  # --json: the job, its result inside
    assert record["scenario"] == "classic_cross_trap_high" and record["seed"] == 102, record
    assert record["outcome"] in ("success", "timeout", "collision_pedestrian", "collision_static")
    assert Path("/tmp/ep.png").stat().st_size > 0
    out = _run(demo, scratch)
    assert "outcomes:" in out and any((scratch / "out" / "demo" / "renders").glob("*.png")), out


def test_importing_reference_files_runs_as_written(scratch: Path, shared_dir: Path) -> None:
    show, convert, render, evaluate = commands(
        section_blocks("Importing the reference system's files", "bash", DOCS / "tutorials" / "simulator.md")[
            0
        ].code
    )
    assert _run(show, scratch).strip()
    _run(convert, scratch)
    assert yaml.safe_load((scratch / "doorway.yaml").read_text())
    _run(render, scratch)
    assert (scratch / "doorway.png").stat().st_size > 0
    # 230 episodes are minutes here: the same command on one scenario, one seed, a 100-step horizon
    small = evaluate.replace(
        "--seeds-per-scenario 10", "--seeds-per-scenario 1 --scenarios classic_cross_trap_low --max-steps 100"
    )
    result = json.loads(_run(small, scratch, ok=(0, 2)))["result"]
    assert result["episodes"] == 1, result


# ---------------------------------------------------------------- the service section


@dataclass
class Service:
    port: int
    proc: subprocess.Popen
    token: str
    work: Path

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def client(self) -> httpx.Client:
        return httpx.Client(base_url=self.url, headers={"Authorization": f"Bearer {self.token}"}, timeout=30)


#: a small campaign for the compare example's CAMPAIGN_ID:1 (README submits none), started first to run meanwhile
CAMPAIGN = {"kind": "campaign", "planner": {"name": "goal"}, "scenarios": ["crossing_low"], "seeds_per_scenario": 1,
            "max_steps": 200, "seed_manifest": "seeds/classic_eval_hard_smoke.yaml",
            "variants": [{"name": f"speed{v}", "config": {"speed": v}} for v in (0.8, 1.2)]}  # fmt: skip


@pytest.fixture(scope="module")
def service(scratch: Path) -> Iterator[Service]:
    """README's quickstart `foresight up` line on a free port, with the scratch HOME: a fresh data folder and token."""
    (up,) = commands(section_blocks(QUICKSTART[1], "bash")[0].code)
    assert "--port 8000" in up
    port = free_port()
    log = (scratch.parent / "up.log").open("w")
    proc = subprocess.Popen(
        ["bash", "-c", f"exec {up.replace('--port 8000', f'--port {port}')}"],
        cwd=scratch,
        env={
            **_env(scratch),
            "FORESIGHT_POLL_S": "0.05",
            "FORESIGHT_HEARTBEAT_S": "0.3",
            "FORESIGHT_SHUTDOWN_GRACE_S": "1",
        },
        stdout=log,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    token_file = scratch.parent / "home/.local/share/foresight/api-token"
    try:
        deadline = time.monotonic() + 90
        while True:
            assert proc.poll() is None, (scratch.parent / "up.log").read_text()[-3000:]
            assert time.monotonic() < deadline, "foresight up not ready in 90 s"
            try:
                if (
                    token_file.is_file()
                    and httpx.get(f"http://127.0.0.1:{port}/v1/workers").json()["count"] >= 1
                ):
                    break
            except (httpx.HTTPError, KeyError, ValueError):
                pass
            time.sleep(0.3)
        yield Service(port, proc, token_file.read_text().strip(), scratch)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(timeout=10)


def _curl_spec() -> dict:
    """The job spec of the service page's curl submission (its `-d` body)."""
    curl = section_blocks("The service", "bash", SERVICE)[1].code
    return json.loads(re.search(r"-d '(.*?)'", curl, flags=re.S).group(1))["spec"]


def test_service_section_runs_as_written(service: Service, scratch: Path) -> None:
    with service.client() as api:
        r = api.post("/v1/jobs", json={"spec": CAMPAIGN, "name": "readme campaign"})
        assert r.status_code == 201, r.text
        campaign_id = r.json()["id"]
    cli, curls = (commands(b.code) for b in section_blocks("The service", "bash", SERVICE))
    lines = dict(
        zip(
            ("up", "submit", "evaluate", "import", "train", "jobs", "models", "compare", "report"),
            cli,
            strict=True,
        )
    )
    assert len(cli) == 9, cli
    assert (
        lines["up"].split("#")[0].split()[1:]
        == commands(section_blocks(QUICKSTART[1], "bash")[0].code)[0].split("#")[0].split()[1:]
    ), "the service page's `foresight up` is not the quickstart's, which the server runs"
    # the import (~40 s of one core here) runs beside the commands that do not need its dataset
    import_log = scratch.parent / "import.log"
    with import_log.open("w") as log:
        importing = subprocess.Popen(
            ["bash", "-e", "-c", lines["import"]],
            cwd=scratch,
            env=_env(scratch),
            stdout=log,
            stderr=subprocess.STDOUT,
        )
    # `spec.yaml`: the spec README's curl example submits, as YAML
    (scratch / "spec.yaml").write_text(yaml.safe_dump(_curl_spec()))
    _run(lines["submit"], scratch, ok=(0, 2))
    with service.client() as api:
        eval_a = api.get("/v1/jobs", params={"kind": "evaluate"}).json()["data"][0]["id"]
    evaluation = json.loads(_run(lines["evaluate"], scratch, ok=(0, 2)))
    eval_b = evaluation["id"]  # --json against a server: the finished job, its result inside
    assert evaluation["kind"] == "evaluate" and evaluation["result"]["episodes"] >= 1, evaluation
    assert importing.wait(timeout=240) == 0, import_log.read_text()[-3000:]
    with service.client() as api:
        (imported,) = api.get("/v1/jobs", params={"kind": "import_dataset"}).json()["data"]
        (dataset_id,) = [d["id"] for d in api.get("/v1/datasets").json() if d["job_id"] == imported["id"]]
    train_job = _run(lines["train"].replace("DATASET_ID", dataset_id), scratch).strip()
    assert re.fullmatch(r"[0-9a-f]{12,32}", train_job), train_job
    listed = json.loads(_run(lines["jobs"], scratch))
    assert {j["kind"] for j in listed["data"]} >= {"evaluate", "import_dataset", "train", "campaign"}
    assert "default" in _run(lines["models"], scratch)
    diff = _run(lines["compare"].replace("EVAL_A", eval_a).replace("EVAL_B", eval_b), scratch)
    assert diff.strip()
    _run(lines["report"].replace("JOB_ID", eval_a), scratch)
    assert (scratch / "report" / "report.md").is_file() and (scratch / "report" / "report.html").is_file()

    token = curls[0]
    assert token.startswith("TOKEN=")
    posted = json.loads(_run(curls[1].replace("localhost:8000", f"localhost:{service.port}"), scratch, token))
    assert posted["spec"]["kind"] == "evaluate", posted
    with service.client() as api:
        assert wait_job(api, posted["id"], timeout=120)["status"] == "succeeded"
        assert wait_job(api, campaign_id, timeout=120)["status"] == "succeeded"
    ids = {"JOB_ID": posted["id"], "EVAL_ID": eval_b, "CAMPAIGN_ID": campaign_id}
    outputs = []
    for curl in curls[2:]:
        for name, value in ids.items():
            curl = curl.replace(name, value)
        curl = re.sub(r"\bID\b", eval_a, curl).replace("localhost:8000", f"localhost:{service.port}")
        outputs.append(json.loads(_run(curl, scratch, token)))
    job, ev, compared, models = outputs
    assert job["status"] == "succeeded" and job["result"]["episodes"] == 2, job
    assert ev["metrics"]["episodes"] >= 1 and ev["per_scenario"] and "taxonomy" in ev, ev
    assert "config_diff" in compared or "deltas" in compared, compared
    assert models["count"] >= 1, models


def test_quickstart_runs_from_any_folder(service: Service, scratch: Path) -> None:
    """README's quickstart from an empty folder (no checkout, no configs): the first evaluation, its report, and
    the player URL of each episode, which the dashboard serves."""
    anywhere = scratch.parent / "anywhere"
    anywhere.mkdir()
    evaluate, report, episodes = commands(section_blocks(QUICKSTART[1], "bash")[1].code)
    out = _run(evaluate, anywhere, ok=(0, 2))
    assert re.search(r"success +\d+\.\d%", out) and "gate:" in out, out
    job = re.findall(r"job ([0-9a-f]{32})", out)[-1][:12]  # the id it prints last, shortened as README allows
    _run(report.replace("JOB_ID", job), anywhere)
    assert (anywhere / "report" / "report.html").is_file() and (anywhere / "report" / "report.md").is_file()
    players = re.findall(r"http://\S+/ui/evaluations/\S+", _run(episodes.replace("JOB_ID", job), anywhere))
    assert len(players) == 4, players  # two scenarios x two seeds
    page = httpx.get(players[0], timeout=30)
    assert page.status_code == 200 and "<canvas" in page.text, page.text[:500]
    assert sorted(p.name for p in anywhere.iterdir()) == ["report"]  # nothing else written where it ran


# ---------------------------------------------------------------- commands quoted in the pages' prose


def _quoting_text() -> str:
    """README and every documentation page: the commands they quote are checked alike."""
    return "\n".join(path.read_text() for path in pages())


def _inline_commands() -> list[str]:
    """Every `foresight ...` command README or a documentation page quotes inline (`[--opt]` optional parts and `a|b`
    alternatives included)."""
    text = re.sub(r"```.*?```", "", _quoting_text(), flags=re.S)
    return sorted({" ".join(m.split()) for m in re.findall(r"`(?:\.venv/bin/)?(foresight [^`]*)`", text)})


def _parser_options(words: list[str]) -> tuple[list[str], set[str]]:
    """The command path of `words` that exists in the CLI's parser, and the option strings its parser takes."""
    from foresight.cli.main import build_parser

    parser, path = build_parser(), []
    for word in words:
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs or word not in subs[0].choices:
            break
        parser, path = subs[0].choices[word], [*path, word]
    return path, {o for a in parser._actions for o in a.option_strings}


@pytest.mark.parametrize("line", _inline_commands())
def test_inline_commands_and_flags_exist(line: str) -> None:
    words = shlex.split(line.replace("[", " ").replace("]", " "))[1:]
    first, *rest = words
    for alternative in first.split("|"):  # `evaluate|diagnose`
        path, options = _parser_options([alternative, *rest])
        assert path, f"README or docs/ quotes `{line}`: foresight has no command {alternative!r}"
        flags = {w.split("=", 1)[0] for w in words if w.startswith("-")}
        assert flags <= options, (
            f"README or docs/ quotes `{line}`: `foresight {' '.join(path)}` has no {flags - options}"
        )


def _bench_commands() -> list[str]:
    """Every `bench/...py` command README or a documentation page quotes (the benchmarks' tables included): minutes
    to hours each."""
    quoted = re.findall(r"`(?:nice -n 5 )?(?:\.venv/bin/python )?(bench/[^`\s][^`]*)`", _quoting_text())
    return sorted({" ".join(m.split()) for m in quoted})


@pytest.mark.parametrize("line", _bench_commands())
def test_benchmark_commands_and_flags_exist(line: str) -> None:
    """Benchmarks are not run here (minutes to an hour each); each script named exists and declares each flag."""
    script, *args = line.split()
    files = sorted(REPO.glob(script))
    assert files, f"README or docs/ quotes `{line}`: no {script}"
    for path in files:
        source = path.read_text()
        missing = [a for a in args if a.startswith("--") and f'"{a}"' not in source]
        assert not missing, f"README or docs/ quotes `{line}`: {path.relative_to(REPO)} declares no {missing}"
