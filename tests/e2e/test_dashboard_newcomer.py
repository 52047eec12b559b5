"""The dashboard as a newcomer uses it, in Debian's Chromium against a real `foresight up`: an evaluation submitted
from the form (built from the spec schema), two evaluations picked on the compare page (no Python ``None``), the
report embedded whole and with its way back, the favicon, Maps in the navigation, the player's downloads and a
pipeline's children named by stage. A screenshot each under out/screenshots/."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.e2e.service import TOKEN, WAIT_MS, Up, wait_job, wait_player
from tests.e2e.test_dashboard import chromium, page, screenshot_dir  # noqa: F401 (fixtures)

pytestmark = pytest.mark.slow
REPO = Path(__file__).resolve().parents[2]
ORCA = {
    "kind": "evaluate",
    "planner": {"name": "orca"},
    "scenarios": ["crossing_low"],
    "seeds_per_scenario": 2,
    "max_steps": 40,
}


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Up]:
    up = Up(tmp_path_factory.mktemp("newcomer"), concurrency=2).start()
    try:
        yield up
    finally:
        up.stop()


def _accept_token(tab) -> None:  # noqa: ANN001
    tab.on("dialog", lambda d: d.accept(TOKEN) if d.type == "prompt" else d.accept())


def test_form_compare_report_maps_player_and_children(service: Up, page) -> None:  # noqa: ANN001, F811
    _accept_token(page)
    api, shots = service.client(), screenshot_dir()

    # an evaluation submitted from the form: the fields are the spec schema's, the API validates what is posted
    page.goto(f"{service.url}/ui/jobs")
    page.click("#new-evaluation")
    assert page.input_value("#f-matrix") == "scenarios/classic_interactions.yaml"
    assert json.loads(page.input_value("#f-planner")) == {"name": "social_force"}
    page.fill("#f-scenarios", "crossing_low")
    page.fill("#f-seeds_per_scenario", "2")
    page.fill("#f-max_steps", "40")
    page.fill("#f-job-name", "from the form")
    page.screenshot(path=str(shots / "newcomer-form.png"), full_page=True)
    page.click("#submit-job")
    page.wait_for_url(re.compile(r"/ui/jobs/[0-9a-f]{32}$"), timeout=WAIT_MS)
    first = page.url.rsplit("/", 1)[1]
    job = wait_job(api, first, timeout=300)
    assert job["status"] == "succeeded" and job["name"] == "from the form", job
    assert job["spec"]["scenarios"] == ["crossing_low"] and job["spec"]["max_steps"] == 40
    second = wait_job(api, api.post("/v1/jobs", json={"spec": ORCA}).json()["id"], timeout=300)["id"]

    # a bad value comes back as the API's own error, the page stays
    page.goto(f"{service.url}/ui/jobs/new?kind=evaluate")
    page.fill("#f-planner", '{"name": "sociall_force"}')
    page.click("#submit-job")
    page.wait_for_selector("#flash:not([hidden])", timeout=WAIT_MS)
    assert "did you mean 'social_force'" in page.text_content("#flash")
    assert page.url.endswith("/ui/jobs/new?kind=evaluate")

    # the report embedded in the job page is as tall as the report; the report page leads back to its job
    page.goto(f"{service.url}/ui/jobs/{first}")
    page.wait_for_selector("iframe.report[data-fitted='1']", timeout=WAIT_MS)
    inner, outer = page.eval_on_selector(
        "iframe.report", "f => [f.contentDocument.documentElement.scrollHeight, f.clientHeight]"
    )
    assert outer >= inner, (inner, outer)
    page.screenshot(path=str(shots / "newcomer-job-report.png"), full_page=True)
    page.goto(f"{service.url}/ui/jobs/{first}/files/report.html")
    page.click("a[href^='player/']")  # a failed episode of the report, in the dashboard's player
    wait_player(page)
    assert f"/ui/evaluations/{first}/episodes/crossing_low/" in page.url
    page.goto(f"{service.url}/ui/jobs/{first}/files/report.html")
    page.click(f"nav.foresight-nav a[href='/ui/jobs/{first}']")
    page.wait_for_url(f"{service.url}/ui/jobs/{first}")

    # compare: two pickers offering the evaluations; what differs shows no Python None
    page.goto(f"{service.url}/ui/compare")
    assert page.locator("#pick-a option").count() >= 3  # the prompt and both evaluations
    page.select_option("#pick-a", first)
    page.select_option("#pick-b", second)
    page.click("form.filters button[type=submit]")
    page.wait_for_selector("#differs")
    body = page.text_content("main")
    assert "None" not in body and "(none)" in body and "orca" in page.text_content("#differs")
    page.screenshot(path=str(shots / "newcomer-compare.png"), full_page=True)

    # the favicon exists; Maps has its own entry and draws the maps
    icon = page.request.get(f"{service.url}/favicon.ico")
    assert icon.status == 200 and icon.body()[:4] == b"\x89PNG"
    page.click("header nav a:text('Maps')")
    page.wait_for_url(f"{service.url}/ui/maps")
    page.click("a.matrix-maps:text('scenarios/classic_interactions.yaml')")
    page.wait_for_selector("figure.map img")
    page.wait_for_function(
        "Array.from(document.querySelectorAll('figure.map img')).slice(0, 2)"
        ".every(i => i.complete && i.naturalWidth > 0)",
        timeout=WAIT_MS,
    )
    assert page.get_attribute("header nav a.on", "href") == "/ui/maps"
    page.screenshot(path=str(shots / "newcomer-maps.png"))

    # the player's downloads: the trace as JSON, the current frame as PNG
    episode = api.get(f"/v1/evaluations/{first}/episodes").json()[0]
    page.goto(f"{service.url}{episode['player']}")
    wait_player(page)
    with page.expect_download() as got:
        page.click("#download-trace")
    trace = json.loads(Path(got.value.path()).read_text())
    assert (
        got.value.suggested_filename == f"{episode['scenario']}__{episode['seed']}.json" and trace["frames"]
    )
    with page.expect_download() as got:
        page.click("#download-frame")
    assert Path(got.value.path()).read_bytes()[:4] == b"\x89PNG"
    page.screenshot(path=str(shots / "newcomer-player.png"), full_page=True)

    # a pipeline's children are named by their stage on its page
    spec = {"kind": "pipeline", **json.loads(json.dumps(_smoke()))}
    pipeline = api.post("/v1/jobs", json={"spec": spec}).json()["id"]
    try:
        page.wait_for_timeout(500)
        for _ in range(240):
            if api.get(f"/v1/jobs/{pipeline}").json().get("children"):
                break
            page.wait_for_timeout(500)
        page.goto(f"{service.url}/ui/jobs/{pipeline}")
        stage = page.text_content("table.children tbody tr td")
        assert stage.startswith("stage "), stage
        page.screenshot(path=str(shots / "newcomer-pipeline-children.png"), full_page=True)
    finally:
        api.post(f"/v1/jobs/{pipeline}/cancel")


def _smoke() -> dict:
    import yaml

    return yaml.safe_load((REPO / "configs" / "pipelines" / "smoke.yaml").read_text())
