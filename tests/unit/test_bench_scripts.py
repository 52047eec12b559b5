"""Every script under bench/ runs: each, run as its own process at tiny sizes (``SMOKE`` in
tests/unit/bench_scripts.py), exits 0 and prints one strict JSON object with its keys, so a refusal (a limit, a
renamed import, a changed config) shows here and not the next time someone runs the benchmark."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from foresight.core.sim.trace import MAX_TRACE_BYTES, trace_bytes
from tests.unit.bench_scripts import BENCH, SMOKE, load_bench, scripts

REPO = BENCH.parent
_done: dict[str, subprocess.CompletedProcess] = {}


def _strict(constant: str) -> None:
    raise ValueError(f"{constant} is not JSON")


def _run(name: str, work: Path, shared: Path | None) -> subprocess.CompletedProcess:
    """bench/<name>.py with its SMOKE arguments, once per module (a script another reads runs first)."""
    if name not in _done:
        smoke = SMOKE[name]
        if smoke.after is not None:
            first = _run(smoke.after, work, shared)
            assert first.returncode == 0, f"{smoke.after} (which {name} reads) failed"
        if smoke.prepare is not None:
            smoke.prepare(work, shared)
        args = [a.replace("{work}", str(work)).replace("{shared}", str(shared)) for a in smoke.args]
        _done[name] = subprocess.run(
            [sys.executable, str(BENCH / f"{name}.py"), *args],
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=300,
        )
    return _done[name]


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("bench")


def test_every_script_has_a_smoke_entry_and_every_entry_a_script() -> None:
    missing = [name for name in scripts() if name not in SMOKE]
    assert not missing, (
        f"bench/{missing[0]}.py has no smoke entry: add its tiny arguments and the keys of its JSON output to SMOKE "
        "in tests/unit/bench_scripts.py"
    )
    stale = sorted(set(SMOKE) - set(scripts()))
    assert not stale, f"SMOKE in tests/unit/bench_scripts.py names {stale}, which bench/ no longer has"


@pytest.mark.parametrize("name", scripts())
def test_the_script_runs_small_and_prints_its_json(
    name: str, work: Path, request: pytest.FixtureRequest
) -> None:
    assert name in SMOKE, (
        f"bench/{name}.py has no smoke entry: add its tiny arguments and the keys of its JSON output to SMOKE in "
        "tests/unit/bench_scripts.py"
    )
    smoke = SMOKE[name]
    shared = request.getfixturevalue("shared_dir") if smoke.shared else None
    done = _run(name, work, shared)
    assert done.returncode == 0, f"bench/{name}.py exited {done.returncode}:\n{done.stderr[-3000:]}"
    try:
        out = json.loads(done.stdout, parse_constant=_strict)
    except ValueError as exc:
        pytest.fail(f"bench/{name}.py printed no strict JSON object ({exc}):\n{done.stdout[:2000]}")
    assert isinstance(out, dict), f"bench/{name}.py printed a {type(out).__name__}, expected one JSON object"
    assert smoke.keys <= set(out), f"bench/{name}.py: keys {sorted(smoke.keys - set(out))} missing"
    problem = smoke.check(out) if smoke.check else None
    assert problem is None, f"bench/{name}.py: {problem}"


def test_sim_speed_asks_for_no_longer_episode_than_the_trace_limit_takes() -> None:
    open_horizon = load_bench("sim_speed").open_horizon
    assert open_horizon(10, 400) == 400  # the timed steps, where they fit
    for n in (200, 1000, 5000):
        h = open_horizon(n, 100_000)
        assert trace_bytes(h, n) <= MAX_TRACE_BYTES < trace_bytes(h + 1, n)
