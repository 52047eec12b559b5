"""Every chart writes a real, non-blank PNG, also with missing values and without failures."""

from __future__ import annotations

from pathlib import Path

import pytest

from foresight.core.render.charts import (
    Estimate,
    ab_chart,
    ranking_chart,
    rate_bars,
    taxonomy_bars,
    training_curves,
)

from .data import assert_picture, training

E = Estimate


def test_estimate_reads_serialised_rates_and_means() -> None:
    assert E.of({"rate": 0.5, "low": 0.2, "high": 0.8, "count": 1, "n": 2}) == E(0.5, 0.2, 0.8)
    assert E.of({"mean": 1.5, "low": None, "high": 2.0}, "mean") == E(1.5, None, 2.0)
    assert E.of(None) == E(None) and E.of({"rate": None}).value is None


@pytest.mark.parametrize("proxy", [True, False])
def test_training_curves(tmp_path: Path, proxy: bool) -> None:
    s = training(proxy)
    assert_picture(training_curves(s["history"], tmp_path / "c.png", best_epoch=6, title="t"))


def test_rate_bars_with_missing_values(tmp_path: Path) -> None:
    p = rate_bars(
        ["a (n=5)", "b (n=0)", "c"],
        {
            "success": [E(0.5, 0.2, 0.8), E(None), E(1.0, 0.6, 1.0)],
            "collision": [E(0.1, 0.0, 0.3), E(None), E(0.0, 0.0, 0.4)],
        },
        tmp_path / "r.png",
        title="rates",
    )
    assert_picture(p)


def test_taxonomy_bars_with_and_without_failures(tmp_path: Path) -> None:
    assert_picture(
        taxonomy_bars(
            {
                "crossing": {"timeout_freeze": 2, "collision_static": 1},
                "corridor": {"timeout_freeze": 0, "made_up_label": 1},
            },
            tmp_path / "t.png",
        )
    )
    assert_picture(taxonomy_bars({"crossing": {"timeout_freeze": 0}}, tmp_path / "none.png"))


def test_ranking_and_ab_charts(tmp_path: Path) -> None:
    assert_picture(
        ranking_chart(
            ["v1", "v2", "v3"],
            [E(0.75, 0.3, 0.95), E(0.5, 0.15, 0.85), E(None)],
            [E(0.8, 0.6, 0.9), E(0.7, 0.5, 0.85), E(0.1, 0.0, 0.3)],
            tmp_path / "rank.png",
            notes=["a", "b", "c"],
        )
    )
    assert_picture(
        ab_chart(
            {"success": E(0.1, -0.1, 0.3), "collision": E(None)},
            {"min clearance [m]": E(0.05, -0.02, 0.12)},
            ["s1", "s2"],
            [E(0.5, 0.2, 0.8), E(None)],
            [E(0.6, 0.3, 0.9), E(0.4, 0.1, 0.8)],
            tmp_path / "ab.png",
            labels=("base", "cand"),
        )
    )


def test_svg_by_suffix(tmp_path: Path) -> None:
    p = rate_bars(["a"], {"success": [E(0.5, 0.2, 0.8)]}, tmp_path / "r.svg")
    assert p.read_text().lstrip().startswith("<?xml")
