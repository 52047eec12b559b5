"""The episode player, the gate badges and the compare page in Debian's Chromium: a real `foresight up`, a small
evaluation whose gate fails; its badge on the jobs page, its episodes one click from the job page, the player
loading the stored trace, playing, stepping, and showing the collision at the recorded step; a second planner on
the same episodes compared from the Results page. Screenshots under out/screenshots/."""

from __future__ import annotations

import json
from collections.abc import Iterator

import pytest

from tests.e2e.service import WAIT_MS, Up, wait_job, wait_player
from tests.e2e.test_dashboard import chromium, page, screenshot_dir  # noqa: F401 (fixtures)

#: goal-seeking robot into dense crowds: collisions within a few seconds; a gate it cannot pass
EVALUATE = {
    "kind": "evaluate",
    "planner": {"name": "goal"},
    "scenarios": ["head_on_corridor_high", "crossing_low"],
    "seeds_per_scenario": 1,
    "max_steps": 120,
    "gate": {"min_success_rate": 1.0},
}

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Up]:
    up = Up(tmp_path_factory.mktemp("player"), concurrency=1).start()
    try:
        yield up
    finally:
        up.stop()


def test_gate_badge_episode_list_and_player(service: Up, page) -> None:  # noqa: ANN001, F811
    api = service.client()
    job_id = api.post("/v1/jobs", json={"spec": EVALUATE}).json()["id"]
    job = wait_job(api, job_id, timeout=600)
    assert job["status"] == "succeeded" and job["verdict"] == "failed_gate", (job, service.log())
    shots = screenshot_dir()

    # the verdict is a badge next to the (green) job status
    page.goto(f"{service.url}/ui/jobs")
    badge = page.locator(f'tr[data-job="{job_id}"] .verdict')
    assert badge.text_content() == "GATE FAILED"
    page.screenshot(path=str(shots / "jobs-gate-badge.png"), full_page=True)

    # every episode one click from the job page, failures first
    page.goto(f"{service.url}/ui/jobs/{job_id[:12]}")  # a short id redirects to the job
    rows = page.locator("table.episodes tbody tr")
    assert rows.count() == 2
    episodes = api.get(f"/v1/evaluations/{job_id}/episodes").json()
    first = episodes[0]
    assert first["outcome"] != "success" and first["player"]
    page.locator("table.episodes a.watch").first.click()
    wait_player(page)
    assert page.url.endswith(first["player"])

    listed = service.cli("evaluations", "episodes", job_id[:12], "--json")  # the same list from the CLI
    assert listed.returncode == 0 and json.loads(listed.stdout) == episodes, listed.stderr

    trace = api.get(first["trace"]).json()
    collision = trace["collision"]
    assert collision is not None and collision["step"] == trace["frames"][-1]
    assert page.get_attribute("#player", "data-step") == "0" and page.is_hidden("#event")
    page.screenshot(path=str(shots / "player-start.png"), full_page=True)

    # play moves the time on; pause stops it
    page.click("#play")
    page.wait_for_function("Number(document.getElementById('player').dataset.frame) >= 3", timeout=WAIT_MS)
    page.click("#play")
    stopped = page.get_attribute("#player", "data-frame")
    page.wait_for_timeout(400)
    assert page.get_attribute("#player", "data-frame") == stopped

    # the slider to the frame before the collision: none shown; one step on: the collision, at its step
    last = len(trace["frames"]) - 1
    page.eval_on_selector(
        "#slider", f"(s) => {{ s.value = '{last - 1}'; s.dispatchEvent(new Event('input')); }}"
    )
    assert int(page.get_attribute("#player", "data-step")) < collision["step"] and page.is_hidden("#event")
    page.click("#fwd")
    assert page.get_attribute("#player", "data-step") == str(collision["step"])
    assert page.is_visible("#event") and f"at step {collision['step']}" in page.text_content("#event")
    page.screenshot(path=str(shots / "player-collision.png"), full_page=True)

    # the same episodes with another planner: the Results page (planner and model columns, verdicts) links the
    # two, and the compare page leads with what differs, then the paired metric deltas
    other = api.post("/v1/jobs", json={"spec": {**EVALUATE, "planner": {"name": "social_force"}}}).json()[
        "id"
    ]
    assert wait_job(api, other, timeout=600)["status"] == "succeeded"
    page.goto(f"{service.url}/ui/results")
    assert "GATE FAILED" in page.text_content("table.results")
    assert [c.text_content() for c in page.locator("td.planner").all()][:2] == ["social_force", "goal"]
    page.screenshot(path=str(shots / "results-verdicts.png"), full_page=True)
    page.locator("a.compare-link").first.click()
    page.wait_for_selector("#differs")
    rows = page.locator("table.differs tbody tr")
    cells = [c.text_content() for c in rows.first.locator("th, td").all()]
    assert rows.count() == 1 and cells == ["planner", "goal", "social_force"], cells
    assert "paired on the same episodes" in page.text_content("#differs")
    page.screenshot(path=str(shots / "compare.png"), full_page=True)

    # the episodes that ended otherwise, by name, each one click from a side-by-side player on one clock
    # (the predictive planner gets out of the way where the goal-seeking robot collides)
    third = api.post(
        "/v1/jobs", json={"spec": {**EVALUATE, "planner": {"name": "predictive", "model": "cv"}}}
    ).json()["id"]
    assert wait_job(api, third, timeout=600)["status"] == "succeeded"
    a, b = job_id, third
    changed = api.get("/v1/compare", params={"a": a, "b": b}).json()["changed_episodes"]
    page.goto(f"{service.url}/ui/compare?a={a}&b={b}")
    assert changed and all(e["a"] != e["b"] and e["player"] for e in changed), changed
    assert page.locator("table.changed tbody tr").count() == len(changed)
    page.locator("table.changed a.watch-pair").first.click()
    wait_player(page)
    first = changed[0]
    assert f"{first['scenario']} seed {first['seed']}" in page.text_content("h1")
    assert page.locator(".pane").count() == 2
    for side in "ab":
        assert f"outcome {first[side]}" in page.text_content(f"#pane-{side} .facts")  # each pane its own run
    page.click("#fwd")
    page.click("#fwd")
    assert page.get_attribute("#player", "data-step") == "2"
    assert [page.get_attribute(f"#pane-{s}", "data-frame") for s in "ab"] == ["2", "2"]  # one clock for both
    page.screenshot(path=str(shots / "compare-side-by-side.png"), full_page=True)


#: two planner-grid variants on the same episodes: the crawling one runs out of time where the other arrives
CAMPAIGN = {
    "kind": "campaign",
    "seed_manifest": "seeds/classic_eval_hard_smoke.yaml",
    "scenarios": ["crossing_low"],
    "seeds_per_scenario": 1,
    "max_steps": 200,
    "variants": [{"name": "base"}, {"name": "crawl", "config": {"max_speed_ratio": 0.1}}],
}


def test_campaign_cells_played_side_by_side(service: Up, page) -> None:  # noqa: ANN001, F811
    """From a campaign's page to a cell's comparison with the baseline cell, to one changed episode in both cells."""
    api = service.client()
    job_id = api.post("/v1/jobs", json={"spec": CAMPAIGN}).json()["id"]
    job = wait_job(api, job_id, timeout=600)
    assert job["status"] == "succeeded", (job, service.log())
    crawl = next(i for i, c in enumerate(job["result"]["ranked"], start=1) if c["variant"] == "crawl")

    page.goto(f"{service.url}/ui/campaigns/{job_id}")
    row = page.locator("table.cells tbody tr").nth(crawl - 1)
    assert "ended otherwise" in row.text_content()
    page.screenshot(path=str(screenshot_dir() / "campaign-cells.png"), full_page=True)
    row.locator("a", has_text="ended otherwise").click()
    page.wait_for_selector("#changed")
    assert "paired on the same episodes" in page.text_content("#differs")
    assert ("crossing_low", "1000") in [
        tuple(c.text_content() for c in r.locator("td").all()[:2])
        for r in page.locator("table.changed tbody tr").all()
    ]
    page.locator("table.changed a.watch-pair").first.click()
    wait_player(page)
    assert page.locator(".pane").count() == 2
    assert [page.text_content(f"#pane-{s} h2").split("· ")[-1] for s in "ab"] == [
        "variant base",
        "variant crawl",
    ]
    outcomes = [page.text_content(f"#pane-{s} .facts") for s in "ab"]
    assert outcomes[0] != outcomes[1] and all("outcome" in o for o in outcomes), outcomes
    page.click("#fwd")
    assert [page.get_attribute(f"#pane-{s}", "data-frame") for s in "ab"] == ["1", "1"]
    page.screenshot(path=str(screenshot_dir() / "campaign-cells-side-by-side.png"), full_page=True)

    # and a cell's own episodes, suite by suite, failures first, each one click from the player
    page.goto(f"{service.url}/ui/campaigns/{job_id}")
    page.locator("table.cells tbody tr").nth(crawl - 1).locator("a.cell-episodes").click()
    page.wait_for_selector("section#hard table.episodes")
    page.screenshot(path=str(screenshot_dir() / "campaign-cell-episodes.png"), full_page=True)
    first = page.locator("section#global table.episodes tbody tr").first
    assert first.locator("td").nth(2).text_content() == "timeout"
    first.locator("a.watch").click()
    wait_player(page)
    assert "crossing_low" in page.text_content("h1") and "campaign cell" in page.text_content("h1")
    assert "outcome timeout" in page.text_content("#facts")
