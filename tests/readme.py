"""The fenced code blocks of README.md and of the documentation pages (docs/), by the page and the section (the
nearest heading) they stand in: the tests that run the documented commands as written read them from here, so the
page is the one copy of each example."""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
DOCS = REPO / "docs"


def pages() -> list[Path]:
    """README.md and every Markdown page of the documentation site."""
    return [README, *sorted(DOCS.rglob("*.md"))]


def page_name(page: Path) -> str:
    """A page's path relative to the repository (``README.md``, ``docs/service.md``)."""
    return page.relative_to(REPO).as_posix()


@dataclass(frozen=True)
class Block:
    section: str  #: the nearest heading above the block, without its #s
    index: int  #: the block's place among the section's blocks of any language (0-based)
    lang: str  #: the fence's language ("bash", "python", "" for plain text)
    code: str

    @property
    def key(self) -> tuple[str, int]:
        return self.section, self.index


def blocks(lang: str | None = None, page: Path = README) -> list[Block]:
    """Every fenced block of a page in order (those of one language when `lang` is given)."""
    out: list[Block] = []
    section, counts = "", {}
    fence = re.compile(r"^```(\w*)\n(.*?)^```", flags=re.S | re.M)
    pos = 0
    text = page.read_text()
    for m in fence.finditer(text):
        for heading in re.findall(r"^#{1,6} (.+)$", text[pos : m.start()], flags=re.M):
            section = heading.strip()
        pos = m.end()
        index = counts.get(section, 0)
        counts[section] = index + 1
        out.append(Block(section, index, m.group(1), m.group(2)))
    return [b for b in out if lang is None or b.lang == lang]


def section_blocks(section: str, lang: str | None = None, page: Path = README) -> list[Block]:
    found = [b for b in blocks(lang, page) if b.section == section]
    assert found, f"{page_name(page)} has no {lang or ''} block under the heading {section!r}"
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
    assert not pending, f"unclosed quote in a documented block: {pending}"
    return out
