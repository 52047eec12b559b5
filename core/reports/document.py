"""One report, two renderings: a block list written once and rendered as Markdown and as self-contained HTML.

Building both from the same blocks keeps the two formats from drifting apart (every section and every
number of the Markdown is on the page). The HTML carries its own CSS and no scripts, and refers to images
and artifacts by paths relative to the report, so the API can serve the folder as is and the page works
offline.
"""

from __future__ import annotations

import html
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from foresight.core import files

CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",sans-serif;max-width:1100px;margin:1.5em auto;padding:0 1em;
color:#222;line-height:1.45}
h1{border-bottom:2px solid #444;padding-bottom:.2em}h2{border-bottom:1px solid #ccc;margin-top:1.6em}
table{border-collapse:collapse;margin:.6em 0;font-size:.9em}th,td{border:1px solid #ccc;padding:.25em .55em;
text-align:left}th{background:#f2f2f2}tr:nth-child(even) td{background:#fafafa}
img{max-width:100%;border:1px solid #ddd;margin:.4em 0}figure{margin:.6em 0}figcaption{font-size:.85em;color:#555}
code{background:#f3f3f3;padding:0 .25em;border-radius:3px}.pass{color:#1a7f37;font-weight:bold}
.fail{color:#c62828;font-weight:bold}.note{color:#555;font-style:italic}
"""

_INLINE = [
    (re.compile(r"\*\*(.+?)\*\*"), r"<strong>\1</strong>"),
    (re.compile(r"`(.+?)`"), r"<code>\1</code>"),
]
_VERDICT = re.compile(r"\b(PASSED|FAILED|passed|failed|ok|FAIL)\b")


def inline_html(text: str) -> str:
    """Escape, then turn Markdown's **bold** and `code` into tags (the only inline markup reports use)."""
    out = html.escape(str(text), quote=False)
    for pattern, repl in _INLINE:
        out = pattern.sub(repl, out)
    return out


@dataclass(frozen=True)
class Link:
    """A table cell that links (a path relative to the report, e.g. an episode's player page)."""

    label: str
    href: str


def _cell_md(x: object) -> str:
    if isinstance(x, Link):
        return f"[{x.label}]({x.href})"
    return str(x).replace("|", "\\|").replace("\n", " ")


def _cell_html(x: object) -> str:
    if isinstance(x, Link):
        return f'<a href="{html.escape(x.href)}">{html.escape(x.label)}</a>'
    return _verdicts(inline_html(x))


@dataclass
class Document:
    """Ordered report blocks; ``markdown()`` and ``html()`` render the same content."""

    title: str
    blocks: list[tuple[str, object]] = field(default_factory=list)

    def section(self, title: str, level: int = 2) -> Document:
        self.blocks.append(("heading", (level, title)))
        return self

    def text(self, text: str) -> Document:
        self.blocks.append(("text", text))
        return self

    def note(self, text: str) -> Document:
        """A remark that a section has no data (so an absent chart is explained, never silently dropped)."""
        self.blocks.append(("note", text))
        return self

    def bullets(self, items: Sequence[str]) -> Document:
        self.blocks.append(("bullets", list(items)))
        return self

    def table(self, header: Sequence[str], rows: Sequence[Sequence[object]]) -> Document:
        self.blocks.append(("table", (list(header), [list(r) for r in rows])))
        return self

    def image(self, src: str, caption: str) -> Document:
        """A picture by its path relative to the report (e.g. ``figures/success.png``)."""
        self.blocks.append(("image", (src, caption)))
        return self

    def links(self, items: Sequence[tuple[str, str]]) -> Document:
        """(label, relative path) pairs."""
        self.blocks.append(("links", list(items)))
        return self

    def images(self) -> list[str]:
        """Relative paths of every picture the report shows, in order."""
        return [data[0] for kind, data in self.blocks if kind == "image"]  # type: ignore[index]

    # ------------------------------------------------------------------ renderings

    def markdown(self) -> str:
        out = [f"# {self.title}", ""]
        for kind, data in self.blocks:
            if kind == "heading":
                level, title = data  # type: ignore[misc]
                out += ["#" * level + " " + title, ""]
            elif kind in ("text", "note"):
                out += [f"_{data}_" if kind == "note" else str(data), ""]
            elif kind == "bullets":
                out += [f"- {item}" for item in data] + [""]  # type: ignore[union-attr]
            elif kind == "table":
                header, rows = data  # type: ignore[misc]
                out.append("| " + " | ".join(_cell_md(h) for h in header) + " |")
                out.append("|" + "---|" * len(header))
                out += ["| " + " | ".join(_cell_md(c) for c in r) + " |" for r in rows]
                out.append("")
            elif kind == "image":
                src, caption = data  # type: ignore[misc]
                out += [f"![{caption}]({src})", ""]
            elif kind == "links":
                out += [f"- [{label}]({href})" for label, href in data] + [""]  # type: ignore[union-attr]
        return "\n".join(out).rstrip() + "\n"

    def _html_block(self, kind: str, data: object) -> str:
        if kind == "heading":
            level, title = data  # type: ignore[misc]
            anchor = re.sub(r"[^a-z0-9]+", "-", title.lower()).strip("-")
            return f'<h{level} id="{anchor}">{inline_html(title)}</h{level}>'
        if kind == "text":
            return f"<p>{_verdicts(inline_html(str(data)))}</p>"
        if kind == "note":
            return f'<p class="note">{inline_html(str(data))}</p>'
        if kind == "bullets":
            return "<ul>" + "".join(f"<li>{_verdicts(inline_html(i))}</li>" for i in data) + "</ul>"  # type: ignore[union-attr]
        if kind == "table":
            header, rows = data  # type: ignore[misc]
            head = "".join(f"<th>{inline_html(h)}</th>" for h in header)
            body = "".join("<tr>" + "".join(f"<td>{_cell_html(c)}</td>" for c in r) + "</tr>" for r in rows)
            return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
        if kind == "image":
            src, caption = data  # type: ignore[misc]
            src_attr = html.escape(src, quote=True)
            return (
                f'<figure><a href="{src_attr}"><img src="{src_attr}" loading="lazy" alt="{html.escape(caption, quote=True)}">'
                f"</a><figcaption>{inline_html(caption)}</figcaption></figure>"
            )
        if kind == "links":
            return (
                "<ul>"
                + "".join(
                    f'<li><a href="{html.escape(h, quote=True)}">{inline_html(label)}</a></li>'
                    for label, h in data
                )
                + "</ul>"
            )  # type: ignore[union-attr]
        raise ValueError(kind)

    def html(self) -> str:
        body = "\n".join(self._html_block(kind, data) for kind, data in self.blocks)
        title = inline_html(self.title)
        return (
            f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{title}</title><style>{CSS}</style></head>\n<body>\n<h1>{title}</h1>\n{body}\n</body></html>\n"
        )

    def write(self, workdir: str | Path, stem: str = "report") -> list[Path]:
        """Write ``<stem>.md`` and ``<stem>.html`` into ``workdir``; returns both paths."""
        workdir = Path(workdir)
        workdir.mkdir(parents=True, exist_ok=True)
        md, page = workdir / f"{stem}.md", workdir / f"{stem}.html"
        files.write_text(md, self.markdown())
        files.write_text(page, self.html())
        return [md, page]


def _verdicts(escaped: str) -> str:
    """Colour pass/fail words in HTML (after escaping; the words contain no markup characters)."""

    def repl(m: re.Match[str]) -> str:
        word = m.group(1)
        cls = "pass" if word.lower() in ("passed", "ok") else "fail"
        return f'<span class="{cls}">{word}</span>'

    return _VERDICT.sub(repl, escaped)
