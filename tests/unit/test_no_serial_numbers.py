"""The project speaks only of itself: no work-history serial numbers ("session" or "issue" followed by a number) in
any tracked file. Dates and commits say when something happened; the text says what a thing is. Names from other
projects keep their spelling (the reference corpus's ``issue_2164_...`` files: an underscore is not matched)."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SERIAL = re.compile(r"\b(session|issue)s? ?[#-]?\d+\b", re.IGNORECASE)


def _tracked() -> list[Path]:
    out = subprocess.run(
        ["git", "ls-files", "-z"], cwd=REPO, capture_output=True, check=True, timeout=60
    ).stdout
    names = [n for n in out.decode().split("\0") if n and not n.startswith(".venv/")]
    return [REPO / n for n in names if (REPO / n).is_file()]


#: the examples are split inside the word, so that this file passes its own scan
@pytest.mark.parametrize(
    ("text", "hit"),
    [
        ("measured in sess" + "ion 29", True),
        ("as Sess" + "ions 18-23 found", True),
        ("the iss" + "ue-12 table", True),
        ("(iss" + "ue 15.5)", True),
        ("see iss" + "ue #7", True),
        ("robot_sf's iss" + "ue_2164_amv_cross_trap_contracts.yaml", False),
        ("vulnerable_user_proxy_pack_v0_deferred_iss" + "ue3654.yaml", False),
        ("a stale session's lease expired after 30 s; issue a token; HTTP 422 issues no job", False),
        ("with Session(engine) as session: session.add(row)", False),
    ],
)
def test_the_pattern(text: str, hit: bool) -> None:
    assert bool(SERIAL.search(text)) is hit, text


def test_no_tracked_file_names_a_serial_number() -> None:
    files = _tracked()
    assert len(files) > 100, "git ls-files found too few files"
    found = []
    for path in files:
        data = path.read_bytes()
        if b"\0" in data[:8192]:  # binary (pictures, checkpoints, archives)
            continue
        for number, line in enumerate(data.decode("utf-8", errors="replace").splitlines(), 1):
            if SERIAL.search(line):
                found.append(f"{path.relative_to(REPO)}:{number}: {line.strip()[:120]}")
    assert not found, (
        "work-history serial numbers (say what the thing is; dates from git log):\n" + "\n".join(found)
    )
