"""`foresight compare --local --players`: two real local evaluations of the same episodes, their changed episodes
written as standalone side-by-side player pages, and one of them played in Debian's Chromium from the file itself
(no server): both panes load their own run, and one clock moves both."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.e2e.service import REPO, wait_player
from tests.e2e.test_dashboard import chromium, page, screenshot_dir  # noqa: F401 (fixtures)

pytestmark = pytest.mark.slow

#: the goal-seeking robot collides in the dense corridor; the predictive planner gets out of the way
RUN = [
    "--matrix",
    "configs/scenarios/classic_interactions.yaml",
    "--scenarios",
    "head_on_corridor_high,crossing_low",
    "--seeds-per-scenario",
    "1",
    "--max-steps",
    "120",
    "--workers",
    "1",
    "--json",
]


def _cli(*args: str, codes: tuple[int, ...] = (0,)) -> str:
    done = subprocess.run(
        [sys.executable, "-m", "foresight.cli.main", *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode in codes, done.stderr
    return done.stdout


def test_changed_episodes_as_player_pages_played_from_the_file(tmp_path: Path, page) -> None:  # noqa: ANN001, F811
    goal, ours = tmp_path / "goal", tmp_path / "predictive"
    _cli(
        "evaluate", "--local", "--planner", "goal", "--out", str(goal), *RUN, codes=(0, 2)
    )  # 2: its gate failed
    _cli(
        "evaluate",
        "--local",
        "--planner",
        "predictive",
        "--model",
        "cv",
        "--out",
        str(ours),
        *RUN,
        codes=(0, 2),
    )
    result = json.loads(
        _cli("compare", "--local", f"goal={goal}", f"ours={ours}", "--players", str(tmp_path / "p"), "--json")
    )
    changed, players = result["changed"]["ours"], result["players"]["ours"]
    assert changed and len(players) == len(changed), result  # both runs kept every episode's trace
    first = changed[0]
    assert Path(players[0]).name == f"{first['scenario']}__{first['seed']}.html"

    page.goto(Path(players[0]).as_uri())
    wait_player(page)
    assert f"goal: {first['a']}" in page.text_content(
        "#pane-0 h2"
    ) and f"ours: {first['b']}" in page.text_content("#pane-1 h2")
    assert f"outcome {first['a']}" in page.text_content("#pane-0 .facts")  # each pane draws its own run
    assert f"outcome {first['b']}" in page.text_content("#pane-1 .facts")
    page.click("#fwd")
    page.click("#fwd")
    assert page.get_attribute("#player", "data-step") == "2"
    assert [page.get_attribute(f"#pane-{i}", "data-frame") for i in (0, 1)] == ["2", "2"]
    page.screenshot(path=str(screenshot_dir() / "compare-local-player.png"), full_page=True)


def test_a_local_campaigns_cells_compare_and_play_like_evaluations(tmp_path: Path) -> None:
    """`foresight campaign --local`: each cell is a run folder, so `compare --local` pairs two cells and writes their
    changed episodes as pages; the campaign's own folder is refused in one line that names its cells."""
    grid = tmp_path / "grid.yaml"
    grid.write_text(
        "variants:\n  - name: base\n    config: {}\n  - name: crawl\n    config: {max_speed_ratio: 0.1}\n"
    )
    run = tmp_path / "campaign"
    _cli(
        "campaign",
        "--local",
        "--matrix",
        "configs/scenarios/classic_interactions.yaml",
        "--seeds",
        "configs/seeds/classic_eval_hard_smoke.yaml",
        "--grid",
        str(grid),
        "--planner",
        "predictive",
        "--checkpoints",
        "cv",
        "--scenarios",
        "crossing_low",
        "--seeds-per-scenario",
        "1",
        "--max-steps",
        "200",
        "--out",
        str(run),
        "--workers",
        "2",
        "--json",
    )
    summary = json.loads((run / "campaign_summary.json").read_text())
    cells = {c["variant"]: run / c["run_dir"] for c in summary["ranked"]}
    result = json.loads(
        _cli(
            "compare",
            "--local",
            f"base={cells['base']}",
            f"crawl={cells['crawl']}",
            "--players",
            str(tmp_path / "p"),
            "--json",
        )
    )
    crawl = next(c for c in summary["ranked"] if c["variant"] == "crawl")
    by_campaign = {(e["scenario"], e["seed"]) for eps in crawl["changed_vs_baseline"].values() for e in eps}
    assert {(e["scenario"], e["seed"]) for e in result["changed"]["crawl"]} == by_campaign and by_campaign
    assert len(result["players"]["crawl"]) == len(by_campaign)  # every episode's trace kept in both cells
    text = _cli(
        "compare",
        "--local",
        f"base={cells['base']}",
        f"crawl={cells['crawl']}",
        "--players",
        str(tmp_path / "p"),
    )  # each changed episode named with its page
    for page_path in result["players"]["crawl"]:
        stem = Path(page_path).stem
        assert any(
            line.endswith(f"  {page_path}") and stem.replace("__", " ") in line for line in text.splitlines()
        )
    refused = subprocess.run(
        [sys.executable, "-m", "foresight.cli.main", "compare", "--local", f"a={run}", f"b={cells['crawl']}"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert refused.returncode != 0 and len(refused.stderr.strip().splitlines()) == 1, refused.stderr
    assert "no episodes.jsonl here (a campaign's folder: compare its cells" in refused.stderr
    assert f"cells/{cells['base'].name}" in refused.stderr
