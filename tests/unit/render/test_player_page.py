"""The standalone player page (core.render.player): traces embedded so that no string in them can end the page's
script, the one player script inlined, one pane per trace; and compare's refusal of --players without --local."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

from foresight.core.render.player import PLAYER_JS, player_page, write_player

REPO = Path(__file__).resolve().parents[3]


def _trace(planner: str) -> dict:
    return {"planner": planner, "outcome": "success", "note": "</script><script>alert(1)</script>"}


def test_the_page_embeds_each_trace_safely_and_the_player_script(tmp_path: Path) -> None:
    text = player_page(
        [("A: success", _trace("goal")), ("B <timeout>", _trace("orca"))], "s 1: A & B", "a note"
    )
    assert text.count('class="pane"') == 2 and 'data-trace-script="trace-1"' in text
    assert "B &lt;timeout&gt;" in text and "s 1: A &amp; B" in text  # labels and title escaped
    blocks = re.findall(r'<script type="application/json" id="trace-(\d)">(.*?)</script>', text, flags=re.S)
    assert [b[0] for b in blocks] == ["0", "1"]
    assert [json.loads(b[1])["planner"] for b in blocks] == ["goal", "orca"]  # intact, every '<' escaped
    assert json.loads(blocks[0][1])["note"] == "</script><script>alert(1)</script>"
    assert text.count("<script>") == 1 and PLAYER_JS.read_text() in text
    path = write_player(tmp_path / "deep" / "page.html", [("A", _trace("goal"))], "t")
    assert path.read_text().count('class="pane"') == 1


def test_players_needs_local_work_folders() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "foresight.cli.main", "compare", "a", "b", "--players", "out"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode != 0 and "--players writes pages from local work folders" in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1, done.stderr


def test_file_names_from_labels_stay_inside_their_folder() -> None:
    from foresight.core.render.episode_trace import episode_stem, safe_name, trace_name

    assert [safe_name(t) for t in ("predictive[cv]", "..", ".", "a/../b")] == [
        "predictive_cv_",
        "_..",
        "_.",
        "a_.._b",
    ]
    assert (
        episode_stem("door/high", 7) == "door_high__7"
        and trace_name("door/high", 7) == "traces/door_high__7.json.gz"
    )
