"""The episode player as a standalone page: compact traces (``core.render.episode_trace``) embedded in one HTML
file with the player script, side by side on one clock. Why: ``foresight compare --local`` has no server to serve
the dashboard's player, and a comparison is understood by watching the episodes that ended otherwise."""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import Any

from foresight.core import files

PLAYER_JS = Path(__file__).with_name("player.js")  #: the one player script (the dashboard serves this file)

_STYLE = """body{font-family:system-ui,sans-serif;margin:1em 1.5em;color:#24292f}
.player-bar{display:flex;align-items:center;gap:.6em;margin:.5em 0}.player-bar input[type=range]{flex:1}
.panes{display:flex;gap:1em}.pane{flex:1;min-width:0}
.pane canvas{width:100%;border:1px solid #d0d7de;border-radius:6px;background:#fff}
.mono{font-family:ui-monospace,monospace;font-size:.9em}.small{font-size:.85em;color:#57606a}
.verdict{display:inline-block;padding:.05em .55em;border-radius:1em;font-size:.85em;font-weight:700;
background:#cf222e;color:#fff}.event[hidden]{display:none}.error{color:#cf222e}"""


def _json_script(ident: str, data: Any) -> str:
    """A JSON <script> block; every '<' is written as its JSON escape, so no string in the data can end (or open)
    an element there."""
    text = json.dumps(data, separators=(",", ":")).replace("<", "\\u003c")
    return f'<script type="application/json" id="{ident}">{text}</script>'


def player_page(traces: list[tuple[str, dict[str, Any]]], title: str, note: str = "") -> str:
    """The HTML of a player with one pane per (label, compact trace), on one clock."""
    panes, data = [], []
    for i, (label, trace) in enumerate(traces):
        panes.append(
            f'<div class="pane" id="pane-{i}" data-trace-script="trace-{i}"><h2>{html.escape(label)}</h2>'
            '<p class="status mono small"></p><span class="event verdict" hidden></span>'
            f'<canvas width="640" height="480" aria-label="episode {html.escape(label)}"></canvas>'
            '<p class="facts small"></p></div>'
        )
        data.append(_json_script(f"trace-{i}", trace))
    return f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title><style>{_STYLE}</style></head>
<body><h1>{html.escape(title)}</h1>
<section id="player">
<div class="player-bar"><button type="button" id="play">play</button>
<button type="button" id="back" title="one frame back (←)">◀</button>
<button type="button" id="fwd" title="one frame on (→)">▶</button>
<input type="range" id="slider" min="0" max="0" value="0" step="1" aria-label="time">
<span id="clock" class="mono">t = 0.0 s</span></div>
<div class="panes">{"".join(panes)}</div>
<p class="small">Blue: the robot, its path and heading; purple: its current command held 2 s; grey: pedestrians
(true ids); amber: the logged forecasts; green: the goal and its tolerance; red: a collision. y points up.
{html.escape(note)}</p>
</section>
{"".join(data)}
<script>{PLAYER_JS.read_text()}</script>
</body></html>
"""


def write_player(
    path: str | Path, traces: list[tuple[str, dict[str, Any]]], title: str, note: str = ""
) -> Path:
    """Write :func:`player_page` to ``path`` (atomically); returns the path."""
    return files.write_text(Path(path), player_page(traces, title, note))


#: what a side-by-side page says of its clock
PAIR_NOTE = "One clock for both runs of the episode; a pane whose episode ended holds its last frame."


def write_pair(
    out: Path, folder: str, scenario: str, seed: int, runs: list[tuple[str, str, Path]], title: str
) -> Path:
    """A side-by-side page of one episode's runs, each (label, outcome, its compact trace file), written as
    ``out/<folder>/<scenario>__<seed>.html`` (names made safe); the panes are headed "label: outcome"."""
    from foresight.core.render.episode_trace import episode_stem, read_compact, safe_name

    return write_player(
        out / safe_name(folder) / f"{episode_stem(scenario, seed)}.html",
        [(f"{label}: {outcome}", read_compact(trace)) for label, outcome, trace in runs],
        title,
        PAIR_NOTE,
    )
