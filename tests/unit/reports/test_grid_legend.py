"""A campaign chart's legend fits its picture: long checkpoint names and many series widen and lengthen the SVG
instead of running off its edge (the dashboard showed them cut)."""

from __future__ import annotations

import re

from foresight.core.reports.grid_plot import ParameterPlot, Point, Series, chart_svg


def test_legend_labels_fit_inside_the_svg() -> None:
    names = ["cv", "model-trained-on-the-stress-suite-2026-12-06", *[f"ck{i}" for i in range(20)]]
    series = [
        Series(name, suite, [Point(x, 0.5, 0.4, 0.6, f"v{x}", 10) for x in (0.5, 1.0)])
        for name in names
        for suite in ("global", "hard")
    ]
    svg = chart_svg(ParameterPlot("speed", [], {"success": series}), "success")
    width, height = (float(v) for v in re.search(r'viewBox="0 0 ([\d.]+) ([\d.]+)"', svg).groups())
    for x, y, text in re.findall(r'<text x="([\d.]+)" y="([\d.]+)" font-size="10">([^<]+)</text>', svg):
        assert float(x) + 6 * len(text) <= width, text
        assert float(y) <= height, text
    assert "model-trained-on-the-stress-suite-2026-12-06 · hard" in svg
