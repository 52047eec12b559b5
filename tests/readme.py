"""README.md's fenced code blocks, by the section (the nearest heading) they stand in: the tests that run README's
commands as written read them from here, so the README is the one copy of each example."""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


@dataclass(frozen=True)
class Block:
    section: str  #: the nearest heading above the block, without its #s
    index: int  #: the block's place among the section's blocks of any language (0-based)
    lang: str  #: the fence's language ("bash", "python", "" for plain text)
    code: str

    @property
    def key(self) -> tuple[str, int]:
        return self.section, self.index


def blocks(lang: str | None = None, path: Path = README) -> list[Block]:
    """Every fenced block of README.md (or another Markdown file) in order (those of one language when `lang` is
    given)."""
    out: list[Block] = []
    section, counts = "", {}
    fence = re.compile(r"^```(\w*)\n(.*?)^```", flags=re.S | re.M)
    pos = 0
    text = path.read_text()
    for m in fence.finditer(text):
        for heading in re.findall(r"^#{1,6} (.+)$", text[pos : m.start()], flags=re.M):
            section = heading.strip()
        pos = m.end()
        index = counts.get(section, 0)
        counts[section] = index + 1
        out.append(Block(section, index, m.group(1), m.group(2)))
    return [b for b in out if lang is None or b.lang == lang]


def section_blocks(section: str, lang: str | None = None) -> list[Block]:
    found = [b for b in blocks(lang) if b.section == section]
    assert found, f"README.md has no {lang or ''} block under the heading {section!r}"
    return found


def commands(code: str) -> list[str]:
    """A block's commands: continuation lines joined, a quoted string across lines kept whole (a JSON body), blank
    lines and whole-line comments dropped."""
    out: list[str] = []
    pending = ""
    for line in re.sub(r"\\\n\s*", " ", code).splitlines():
        if not pending and (not line.strip() or line.lstrip().startswith("#")):
            continue
        pending = f"{pending}\n{line}" if pending else line.strip()
        try:
            shlex.split(pending, comments=True)
        except ValueError:  # an open quote: the command goes on on the next line
            continue
        out.append(pending)
        pending = ""
    assert not pending, f"unclosed quote in README block: {pending}"
    return out
