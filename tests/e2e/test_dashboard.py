"""The dashboard in a real browser: `foresight up` on a temp store, Debian's Chromium driven by Playwright.

Follows an evaluation job in the jobs page until it succeeds, opens its report page and checks that its
figures loaded, cancels and retries jobs through the page's buttons (the token is asked for once), and
saves screenshots under ``out/screenshots/`` (``FORESIGHT_SCREENSHOT_DIR`` overrides).
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.e2e.service import REPO, TOKEN, WAIT_MS, Up, wait_player
from tests.integration.service import tiny_model_job

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
JOB_TIMEOUT_S = 90.0
#: a small real evaluation: goal planner, 2 scenarios x 1 seed, short horizon
EVALUATE = {
    "kind": "evaluate",
    "planner": {"name": "goal"},
    "scenarios": ["crossing_low", "head_on_corridor_low"],
    "seeds_per_scenario": 1,
    "max_steps": 60,
}

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def chromium() -> Path:
    if not CHROMIUM.is_file():
        msg = f"{CHROMIUM} not found: the dashboard test needs Debian's Chromium (apt-get install chromium)"
        if os.environ.get("CI") == "true":
            pytest.fail(msg)
        pytest.skip(msg)
    return CHROMIUM


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Up]:
    up = Up(tmp_path_factory.mktemp("dashboard")).start()
    try:
        yield up
    finally:
        up.stop()


@pytest.fixture
def page(chromium: Path) -> Iterator:  # noqa: ANN401 (playwright's Page)
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=str(chromium), args=CHROMIUM_ARGS, headless=True)
        try:
            context = browser.new_context(viewport={"width": 1280, "height": 900})
            page = context.new_page()
            page.foresight_log = []  # what the browser logged, for failure messages (service.wait_player)
            page.on("console", lambda m: page.foresight_log.append(f"{m.type}: {m.text}"))
            page.on("pageerror", lambda e: page.foresight_log.append(f"pageerror: {e}"))
            page.on(
                "requestfailed", lambda r: page.foresight_log.append(f"requestfailed: {r.url} {r.failure}")
            )
            yield page
        finally:
            browser.close()


def screenshot_dir() -> Path:
    folder = Path(os.environ.get("FORESIGHT_SCREENSHOT_DIR") or REPO / "out" / "screenshots")
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _row_status(page, job_id: str) -> str | None:  # noqa: ANN001
    return page.get_attribute(f'tr[data-job="{job_id}"]', "data-status", timeout=5000)


def _wait_row(
    page, job_id: str, statuses: set[str], timeout_s: float = JOB_TIMEOUT_S, up: Up | None = None
) -> str:  # noqa: ANN001
    """Wait until the jobs page (which refreshes its rows itself) shows the job in one of ``statuses``."""
    deadline = time.monotonic() + timeout_s
    status = None
    while time.monotonic() < deadline:
        status = _row_status(page, job_id)
        if status in statuses:
            return status
        page.wait_for_timeout(300)
    raise AssertionError(
        f"job {job_id} still {status} on the jobs page after {timeout_s} s\n{up.log() if up else ''}"
    )


def test_dashboard_follows_a_job_to_its_report(service: Up, page, capsys: pytest.CaptureFixture) -> None:  # noqa: ANN001
    dialogs: list[str] = []

    def on_dialog(dialog) -> None:  # noqa: ANN001
        dialogs.append(dialog.type)
        if dialog.type == "prompt":
            dialog.accept(TOKEN)
        else:
            dialog.accept()

    page.on("dialog", on_dialog)
    api = service.client()
    kinds = api.get("/healthz").json()["kinds"]
    assert "evaluate" in kinds, (
        f"the server offers no 'evaluate' jobs (kinds {kinds}); the dashboard test needs one"
    )

    page.goto(f"{service.url}/")
    assert page.url.endswith("/ui/jobs")

    def submit(spec: dict, priority: int = 0) -> str:
        resp = api.post("/v1/jobs", json={"spec": spec, "priority": priority})
        assert resp.status_code == 201, resp.text
        return resp.json()["id"]

    failing = submit({"kind": "sleep", "seconds": 0.3, "steps": 2, "fail": "planned failure"}, priority=20)
    evaluation = submit(EVALUATE, priority=10)
    long_sleep = submit({"kind": "sleep", "seconds": 120, "steps": 240})

    # live rows: the new jobs appear without a reload; the failing one ends failed
    _wait_row(page, failing, {"failed"}, 30, service)
    first_run = api.get(f"/v1/jobs/{failing}").json()["started_at"]

    # retry through the page: the first write asks for the token (prompt), which the page keeps
    page.click(f'tr[data-job="{failing}"] button[data-action="post"]')
    deadline = time.monotonic() + 30
    while api.get(f"/v1/jobs/{failing}").json()["started_at"] == first_run and time.monotonic() < deadline:
        time.sleep(0.2)
    assert api.get(f"/v1/jobs/{failing}").json()["started_at"] != first_run, "retry did not run the job again"
    assert dialogs.count("prompt") == 1
    assert page.evaluate("sessionStorage.getItem('foresight-token')") == TOKEN

    # cancel through the page (a confirm dialog, no second token prompt)
    _wait_row(page, long_sleep, {"queued", "running"}, 10, service)
    page.click(f'tr[data-job="{long_sleep}"] button[data-action="post"]')
    _wait_row(page, long_sleep, {"cancelled"}, 30, service)
    assert dialogs.count("prompt") == 1 and "confirm" in dialogs

    # the evaluation: followed in the jobs page until it succeeds, then its report link
    status = _wait_row(page, evaluation, {"succeeded", "failed", "cancelled"}, JOB_TIMEOUT_S, service)
    assert status == "succeeded", api.get(f"/v1/jobs/{evaluation}").json()["error"]
    report_file = service.store / "jobs" / evaluation / "report.html"
    assert report_file.is_file(), (
        f"the worker wrote no report for the evaluate job ({report_file} missing): the worker is expected to call "
        "foresight.core.reports.stage.write_stage_report(kind, result, workdir) after a stage succeeds"
    )
    shots = screenshot_dir()
    page.screenshot(path=str(shots / "dashboard-jobs.png"), full_page=True)

    page.click(f'tr[data-job="{evaluation}"] a[href="/ui/jobs/{evaluation}"]')
    page.wait_for_selector("#report-link", timeout=WAIT_MS)
    page.wait_for_function(
        "document.getElementById('job-log').dataset.ended === 'succeeded'", timeout=WAIT_MS
    )
    assert "succeeded" in page.inner_text("#job-log")
    assert page.locator("a", has_text="evaluation.json").count() == 1  # artifacts with links
    page.screenshot(path=str(shots / "dashboard-job.png"), full_page=True)

    report_url = page.get_attribute("#report-link", "href")
    assert report_url == f"/ui/jobs/{evaluation}/files/report.html"
    page.goto(service.url + report_url)
    page.wait_for_load_state("load")
    for img in page.locator("img").all():
        img.scroll_into_view_if_needed()  # figures are lazy-loaded
    page.wait_for_function("[...document.images].every(i => i.complete)", timeout=WAIT_MS)
    sizes = page.evaluate("[...document.images].map(i => [i.getAttribute('src'), i.naturalWidth])")
    assert sizes, "the report page shows no figures"
    assert all(width > 0 for _, width in sizes), f"figures that did not load: {sizes}"
    assert any(src.startswith("figures/") for src, _ in sizes)
    path = shots / "dashboard-report.png"
    page.screenshot(path=str(path), full_page=True)

    # the results page lists the evaluation with its report
    page.goto(f"{service.url}/ui/results")
    assert page.locator(f'a[href="{report_url}"]').count() == 1

    with capsys.disabled():
        print(
            f"\ndashboard screenshots: {shots / 'dashboard-jobs.png'}, {shots / 'dashboard-job.png'}, {path}"
        )


def test_an_evaluations_failures_get_witnesses_from_its_page(service: Up, page) -> None:  # noqa: ANN001
    """The evaluation's page submits a witness job for its failures and follows it to its report and players."""
    page.on("dialog", lambda dialog: dialog.accept(TOKEN) if dialog.type == "prompt" else dialog.accept())
    api = service.client()
    spec = {
        "kind": "evaluate",
        "planner": {"name": "goal"},
        "scenarios": ["crossing_medium"],
        "seeds_per_scenario": 3,
        "scenario_overrides": {"simulation_config": {"ped_speed_tier": "typical"}},
    }
    evaluation = api.post("/v1/jobs", json={"spec": spec, "priority": 30}).json()["id"]
    deadline = time.monotonic() + JOB_TIMEOUT_S
    while api.get(f"/v1/jobs/{evaluation}").json()["status"] != "succeeded" and time.monotonic() < deadline:
        time.sleep(0.3)
    page.goto(f"{service.url}/ui/jobs/{evaluation}")
    button = page.locator("#witness-btn")
    assert "failed episode" in button.inner_text()
    assert '"price": false' in button.get_attribute("data-body")  # the goal robot does not price a course
    button.click()  # asks for the token, submits, and follows the new job on its own page
    page.wait_for_url(lambda url: "/ui/jobs/" in url and evaluation not in url, timeout=WAIT_MS)
    witness = page.url.rsplit("/", 1)[-1]
    assert api.get(f"/v1/jobs/{witness}").json()["spec"]["evaluation"] == evaluation
    page.wait_for_selector(
        "#witnesses a.watch", timeout=WAIT_MS
    )  # the page reloads itself when the job has ended
    assert api.get(f"/v1/jobs/{witness}").json()["status"] == "succeeded"
    assert page.locator("#report-link").count() == 1  # and its report
    page.click("#witnesses a.watch >> nth=0")
    wait_player(page)  # the planner's run and the witness, one clock
    assert page.locator(".pane").count() == 2 and "planner" in page.inner_text("#pane-planner h2")
    assert "witness" in page.inner_text("#pane-witness h2")
    page.screenshot(path=str(screenshot_dir() / "dashboard-witness.png"), full_page=True)


def test_dashboard_map_previews_and_models(service: Up, page) -> None:  # noqa: ANN001
    page.goto(f"{service.url}/ui/bundles")
    page.click("text=scenarios/classic_interactions.yaml")
    first = page.locator("figure.map img").first
    first.wait_for(timeout=WAIT_MS)
    page.wait_for_function(
        "document.querySelector('figure.map img').complete "
        "&& document.querySelector('figure.map img').naturalWidth > 0",
        timeout=WAIT_MS,
    )
    page.screenshot(path=str(screenshot_dir() / "dashboard-matrix.png"))
    # a registered model (a tiny trained checkpoint: registration takes nothing else): promote it, then default
    api = service.client()
    job = tiny_model_job(api)
    model = {
        "id": "e2e-model",
        "job_id": job,
        "artifact": "model.pt",
        "metrics": {"ade": 0.31},
        "lineage": {"datasets": ["base-e2e"]},
    }
    assert api.post("/v1/models", json=model).status_code == 201
    page.on("dialog", lambda dialog: dialog.accept(TOKEN) if dialog.type == "prompt" else dialog.accept())
    page.goto(f"{service.url}/ui/models")
    row = 'tr[data-model="e2e-model"]'
    assert page.inner_text(f"{row} .status") == "candidate"
    page.click(f"{row} button:text('promote')")
    page.wait_for_function(
        f"document.querySelector('{row} .status').textContent === 'promoted'", timeout=WAIT_MS
    )
    page.click(f"{row} button:text('make default')")
    page.wait_for_function(
        f"document.querySelector('{row} .status').textContent === 'default'", timeout=WAIT_MS
    )
    assert api.get("/v1/models/e2e-model").json()["status"] == "default"
    page.screenshot(path=str(screenshot_dir() / "dashboard-models.png"), full_page=True)
    page.goto(f"{service.url}/ui/results")
    page.screenshot(path=str(screenshot_dir() / "dashboard-results.png"), full_page=True)


@pytest.fixture(scope="module")
def closed_service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Up]:
    up = Up(tmp_path_factory.mktemp("dashboard-closed"), concurrency=1, read_requires_token=True).start()
    try:
        yield up
    finally:
        up.stop()


def test_closed_reads_ask_for_the_token_then_stream(closed_service: Up, page) -> None:  # noqa: ANN001
    answers = ["wrong-token", TOKEN]
    page.on(
        "dialog", lambda dialog: dialog.accept(answers.pop(0)) if dialog.type == "prompt" else dialog.accept()
    )
    resp = page.goto(f"{closed_service.url}/ui/jobs")
    assert resp.status == 401 and page.locator("h1", has_text="Token required").count() == 1

    page.click('[data-action="token-reload"]')  # a wrong token: the page asks again
    page.wait_for_load_state("load")
    assert page.locator("h1", has_text="Token required").count() == 1
    page.click('[data-action="token-reload"]')
    page.wait_for_selector("#job-rows")
    assert page.locator("h1", has_text="Jobs").count() == 1

    api = closed_service.client()
    job = api.post("/v1/jobs", json={"spec": {"kind": "sleep", "seconds": 2.5, "steps": 10}}).json()["id"]
    _wait_row(page, job, {"queued", "running"}, 15, closed_service)  # rows refresh with the cookie
    page.click(f'tr[data-job="{job}"] a[href="/ui/jobs/{job}"]')
    page.wait_for_selector("#job-log")
    # the event stream (sent with the token header) follows the job; at its end the page reloads itself
    page.wait_for_function("document.querySelector('#job-summary').dataset.final === '1'", timeout=WAIT_MS)
    page.wait_for_function(
        "document.getElementById('job-log').dataset.ended === 'succeeded'", timeout=WAIT_MS
    )
    log = page.inner_text("#job-log")
    assert "step 10/10" in log and "succeeded" in log
    assert page.locator("#job-summary .status", has_text="succeeded").count() == 1
