"""Markdown and HTML render the same blocks; the page is self-contained and escapes its text."""

from __future__ import annotations

from pathlib import Path

from foresight.core.reports.document import Document

from .data import assert_page


def _doc() -> Document:
    doc = Document("Report <1>")
    doc.section("Summary").text("Status **passed**, rate `0.5` & more").note("nothing here")
    doc.section("Table").table(["a", "b|c"], [[1, "x|y"], ["<b>", "FAILED"]])
    doc.section("Pictures").image("figures/a.png", "A picture").links([("data", "evaluation.json")])
    doc.bullets(["one", "two"])
    return doc


def test_markdown_has_every_block() -> None:
    md = _doc().markdown()
    for part in (
        "# Report <1>",
        "## Summary",
        "## Table",
        "## Pictures",
        "Status **passed**",
        "_nothing here_",
        "| a | b\\|c |",
        "| 1 | x\\|y |",
        "![A picture](figures/a.png)",
        "- [data](evaluation.json)",
        "- two",
    ):
        assert part in md, part


def test_html_is_escaped_self_contained_and_relative(tmp_path: Path) -> None:
    doc = _doc()
    paths = doc.write(tmp_path)
    assert [p.name for p in paths] == ["report.md", "report.html"]
    page = paths[1].read_text()
    assert_page(page)
    assert "<title>Report &lt;1&gt;</title>" in page and "<td>&lt;b&gt;</td>" in page
    assert (
        "&lt;b&gt;" in page
        and '<strong><span class="pass">passed</span></strong>' in page
        and "<code>0.5</code>" in page
    )
    assert '<img src="figures/a.png"' in page and '<a href="evaluation.json">' in page
    assert '<h2 id="summary">Summary</h2>' in page and 'class="fail">FAILED' in page
    assert doc.images() == ["figures/a.png"]
