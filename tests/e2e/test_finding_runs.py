"""Finding runs again, on a real `foresight up` (API server + worker, temp SQLite file) with Debian's Chromium:
docs/service.md's "Finding and organising runs" block as written, the CLI's labels and lists, the jobs page's tag filter,
and a real campaign's grid plots page. Screenshots go to ``out/screenshots/`` (``FORESIGHT_SCREENSHOT_DIR``)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.e2e.service import REPO, TOKEN, Up, wait_job
from tests.e2e.test_dashboard import chromium, page, screenshot_dir  # noqa: F401 (fixtures)
from tests.readme import DOCS, section_blocks

pytestmark = pytest.mark.slow

#: three goal-planner variants differing in one numeric key (speed), on one scenario and the smoke hard seeds
CAMPAIGN = {
    "kind": "campaign",
    "planner": {"name": "goal"},
    "scenarios": ["crossing_low"],
    "seeds_per_scenario": 1,
    "max_steps": 500,
    "seed_manifest": "seeds/classic_eval_hard_smoke.yaml",
    "variants": [{"name": f"speed{v}", "config": {"speed": v}} for v in (0.6, 1.0, 1.4)],
}


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Up]:
    up = Up(tmp_path_factory.mktemp("finding")).start()
    try:
        yield up
    finally:
        up.stop()


@pytest.fixture(scope="module")
def campaign(service: Up) -> str:
    """A real campaign submitted first, so that it runs while the other tests do."""
    r = service.client().post(
        "/v1/jobs", json={"spec": CAMPAIGN, "name": "speed sweep", "tags": ["grid", "goal"]}
    )
    assert r.status_code == 201, r.text
    return r.json()["id"]


def _readme_block() -> str:
    (block,) = section_blocks("Finding and organising runs", "bash", DOCS / "service.md")
    return block.code


def test_readme_block_runs_as_written(service: Up, campaign: str, tmp_path: Path) -> None:
    home = tmp_path / "home"
    (home / ".local/share/foresight").mkdir(parents=True)
    (home / ".local/share/foresight/api-token").write_text(TOKEN)  # where the block reads the token
    code = _readme_block().replace("localhost:8000", f"127.0.0.1:{service.port}")
    env = {
        "PATH": f"{Path(sys.executable).parent}:/usr/bin:/bin",
        "HOME": str(home),
        "FORESIGHT_API_URL": service.url,
        "FORESIGHT_API_TOKEN": TOKEN,
    }
    proc = subprocess.run(
        ["bash", "-e", "-o", "pipefail", "-c", code],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert lines[0] == '{"name":"readme run","tags":["baseline","reviewed"],"note":"kept as the reference"}'
    assert lines[1] == "readme run"  # the tag filter (both tags) finds it
    assert all(x.isdigit() for x in lines[2:5])  # evaluations, campaigns, models counts
    assert lines[5] == "kept as the reference" and lines[6] == '["reviewed"]'


def test_cli_labels_lists_and_jobs_page_tag_filter(service: Up, campaign: str, page) -> None:  # noqa: ANN001, F811
    ids = {}
    for name, tags in (("orca baseline", ["baseline", "orca"]), ("mpc trial", ["trial"]), ("untagged", [])):
        proc = service.cli(
            "submit",
            "sleep",
            "--name",
            name,
            *[f"--tag={t}" for t in tags],
            "--note",
            f"{name} note",
            "--json",
        )
        assert proc.returncode == 0, proc.stderr
        ids[name] = json.loads(proc.stdout)["id"]
    listed = service.cli("jobs", "ls", "--tag", "baseline", "--json")
    assert listed.returncode == 0 and [j["id"] for j in json.loads(listed.stdout)["data"]] == [
        ids["orca baseline"]
    ]
    text = service.cli("jobs", "ls", "--tag", "trial").stdout
    assert "'mpc trial' #trial" in text and "1 of 1 jobs" in text
    edited = service.cli("jobs", "edit", ids["untagged"][:12], "--tag", "baseline", "--name", "now tagged")
    assert edited.returncode == 0 and "'now tagged' #baseline" in edited.stdout
    stage = service.cli(
        "evaluate",
        "--matrix",
        "configs/scenarios/classic_interactions.yaml",
        "--scenarios",
        "crossing_low",
        "--seeds-per-scenario",
        "1",
        "--planner",
        "goal",
        "--no-wait",
        "--json",
        "--name",
        "from a stage command",
        "--tag",
        "stage-cli",
        "--note",
        "labels on stage commands too",
    )
    assert stage.returncode == 0, stage.stderr
    submitted = json.loads(stage.stdout)
    assert (submitted["name"], submitted["tags"], submitted["note"]) == (
        "from a stage command",
        ["stage-cli"],
        "labels on stage commands too",
    )
    service.client().post(f"/v1/jobs/{submitted['id']}/cancel")
    bad = service.cli("jobs", "edit", ids["untagged"], "--tag", "has space")
    assert bad.returncode == 1 and len(bad.stderr.strip().splitlines()) == 1 and "tags" in bad.stderr

    page.goto(f"{service.url}/ui/jobs")
    page.wait_for_selector('input[name="tag"][value="baseline"]')
    page.check('input[name="tag"][value="baseline"]')
    page.click('form.filters button[type="submit"]')
    page.wait_for_url(re.compile(r".*tag=baseline.*"))
    rows = page.eval_on_selector_all("#job-rows tr[data-job]", "rs => rs.map(r => r.dataset.job)")
    assert sorted(rows) == sorted([ids["orca baseline"], ids["untagged"]])
    assert page.is_checked('input[name="tag"][value="baseline"]')
    page.wait_for_timeout(2500)  # one refresh of the rows keeps the filter
    rows = page.eval_on_selector_all("#job-rows tr[data-job]", "rs => rs.map(r => r.dataset.job)")
    assert sorted(rows) == sorted([ids["orca baseline"], ids["untagged"]])
    page.screenshot(path=str(screenshot_dir() / "dashboard-jobs-tag-filter.png"), full_page=True)
    page.click(f'tr[data-job="{ids["orca baseline"]}"] a.tag:text("orca")')  # a row's tag links to its filter
    page.wait_for_url(re.compile(r".*tag=orca.*"))
    assert page.eval_on_selector_all("#job-rows tr[data-job]", "rs => rs.map(r => r.dataset.job)") == [
        ids["orca baseline"]
    ]
    page.fill('input[name="q"]', "MPC TRIAL NOTE")
    page.uncheck('input[name="tag"][value="orca"]')
    page.click('form.filters button[type="submit"]')
    page.wait_for_url(re.compile(r".*q=MPC.*"))
    assert page.eval_on_selector_all("#job-rows tr[data-job]", "rs => rs.map(r => r.dataset.job)") == [
        ids["mpc trial"]
    ]


def test_campaign_grid_plots_in_the_browser(service: Up, campaign: str, page) -> None:  # noqa: ANN001, F811
    job = wait_job(service.client(), campaign, timeout=300)
    assert job["status"] == "succeeded", job.get("error") or service.log()
    found = service.cli("campaigns", "ls", "--tag", "grid", "--json")
    assert found.returncode == 0 and [c["id"] for c in json.loads(found.stdout)["data"]] == [campaign]
    # a cell's episodes of one suite, failures first, each with the URL of its player
    hard = service.cli("campaigns", "episodes", campaign[:12], "1", "--suite", "hard", "--json")
    episodes = json.loads(hard.stdout)
    assert hard.returncode == 0 and len(episodes) == 6 and all(e["player"] for e in episodes), hard.stderr
    outcomes = [e["outcome"] == "success" for e in episodes]
    assert outcomes == sorted(outcomes)  # failures first
    text = service.cli("campaigns", "episodes", campaign[:12], "1", "--suite", "hard").stdout.splitlines()
    assert [line.split()[-1] for line in text[:-1]] == [f"{service.url}{e['player']}" for e in episodes]
    assert text[-1] == f"6 episodes, {outcomes.count(False)} not successful"
    failed = service.cli("campaigns", "episodes", campaign[:12], "1", "--suite", "hard", "--failed").stdout
    assert len(failed.splitlines()) == outcomes.count(False) + 1
    bad = service.cli("campaigns", "episodes", campaign[:12], "9")
    assert bad.returncode != 0 and "rank 9" in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
    page.goto(f"{service.url}/ui/jobs/{campaign}")
    page.click("#grid-link")
    page.wait_for_selector("svg.grid-chart")
    charts = page.eval_on_selector_all(
        "svg.grid-chart", "cs => cs.map(c => [c.dataset.parameter, c.dataset.metric])"
    )
    assert charts == [["speed", "success"], ["speed", "collision"]]
    # three variants on one checkpoint: a global and a hard line, three points each, in each chart
    assert page.eval_on_selector_all('svg[data-metric="success"] .point', "ps => ps.length") == 6
    assert page.eval_on_selector_all('svg[data-metric="success"] polyline.series', "ps => ps.length") == 2
    tips = page.eval_on_selector_all(
        'svg[data-metric="success"] .point title', "ts => ts.map(t => t.textContent)"
    )
    assert any(t.startswith("speed0.6 @ none, global suite: speed = 0.6, success ") for t in tips), tips
    # every label (the legend's included) is drawn inside its chart, none cut at the edge
    cut = page.eval_on_selector_all(
        "svg.grid-chart",
        """cs => cs.flatMap(c => [...c.querySelectorAll('text')]
        .filter(t => { const b = t.getBBox(), v = c.viewBox.baseVal; return b.x + b.width > v.width + 0.5
                       || b.y + b.height > v.height + 0.5; })
        .map(t => t.textContent))""",
    )
    assert cut == [], cut
    shot = screenshot_dir() / "dashboard-campaign-grid.png"
    page.screenshot(path=str(shot), full_page=True)
    assert shot.stat().st_size > 10_000
