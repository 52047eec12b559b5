"""Hand-built stage results (the JSON the stages write), small enough to check every number in a report."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from foresight.core.evaluation.aggregate import MEANS
from foresight.core.evaluation.stats import bootstrap_mean, rate

LABELS = [
    "collision_pedestrian_robot_fault",
    "collision_pedestrian_pedestrian_fault",
    "collision_static",
    "out_of_bounds",
    "timeout_freeze",
    "timeout_oscillation",
    "timeout_slow_progress",
    "planner_error",
]


def taxonomy(**counts: int) -> dict[str, int]:
    return {lab: counts.get(lab, 0) for lab in LABELS}


def rate_d(k: int, n: int) -> dict[str, Any]:
    return rate(k, n).model_dump(mode="json")


def mean_d(values: list[float]) -> dict[str, Any]:
    return bootstrap_mean(values, samples=200).model_dump(mode="json")


def group(
    key: str,
    success: int,
    collision: int,
    n: int,
    tax: dict[str, int],
    failed_seeds: list[int],
    clearance: list[float],
) -> dict[str, Any]:
    timeout = n - success - collision
    return {
        "key": key,
        "episodes": n,
        "rates": {
            "success": rate_d(success, n),
            "collision": rate_d(collision, n),
            "collision_pedestrian": rate_d(collision, n),
            "collision_static": rate_d(0, n),
            "timeout": rate_d(timeout, n),
            "error": rate_d(0, n),
        },
        "means": {
            **{name: mean_d([]) for name in MEANS},
            "min_clearance": mean_d(clearance),
            "avg_speed": mean_d([0.8] * n),
            "time_to_goal_s": mean_d([12.5] * success),
        },
        "delta_to_global": {"success_rate": 0.05},
        "failed": [
            {"scenario": key, "seed": s, "outcome": "timeout", "label": "timeout_slow_progress"}
            for s in failed_seeds
        ],
        "taxonomy": tax,
    }


def evaluation(failures: bool = True) -> dict[str, Any]:
    """10 episodes on two scenarios of two families; 7 successes, 1 collision, 2 timeouts (or 10/10)."""
    if failures:
        a = group(
            "crossing_low", 4, 0, 5, taxonomy(timeout_slow_progress=1), [1003], [0.9, 1.1, 0.7, 1.3, 0.8]
        )
        b = group(
            "head_on_corridor_high",
            3,
            1,
            5,
            taxonomy(collision_pedestrian_robot_fault=1, timeout_freeze=1),
            [1200, 1204],
            [0.2, 0.4, -0.1, 0.5, 0.3],
        )
        overall = group(
            "global",
            7,
            1,
            10,
            taxonomy(timeout_slow_progress=1, collision_pedestrian_robot_fault=1, timeout_freeze=1),
            [],
            [0.5] * 10,
        )
    else:
        a = group("crossing_low", 5, 0, 5, taxonomy(), [], [1.0] * 5)
        b = group("head_on_corridor_high", 5, 0, 5, taxonomy(), [], [0.6] * 5)
        overall = group("global", 10, 0, 10, taxonomy(), [], [0.8] * 10)
    fam = [dict(a, key="crossing"), dict(b, key="head_on_corridor")]
    dens = [dict(a, key="crossing/low"), dict(b, key="head_on_corridor/high")]
    gate_ok = failures is False
    return {
        "status": "passed" if gate_ok else "failed_gate",
        "exit_code": 0 if gate_ok else 2,
        "success_rate": overall["rates"]["success"]["rate"],
        "collision_rate": overall["rates"]["collision"]["rate"],
        "episodes": 10,
        "planner": {
            "name": "predictive",
            "variant": "careful",
            "config": {},
            "config_hash": "abcdef0123456789",
            "model_id": "m-7",
            "checkpoint_sha256": "deadbeef" * 8,
        },
        "code_version": "0.1.0+test",
        "bundle": "builtin",
        "matrix": "scenarios/classic_interactions.yaml",
        "seed_source": "5 per scenario",
        "horizon": "scenario",
        "workers": 2,
        "aggregates": {
            "overall": overall,
            "per_scenario": [a, b],
            "per_family": fam,
            "per_family_density": dens,
        },
        "taxonomy": overall["taxonomy"],
        "taxonomy_config": {"freeze_min_s": 3.0, "stopped_speed": 0.05},
        "metrics_config": {},
        "integrity": {"ok": True, "checks": ["success_with_collision", "duplicate"], "violations": []},
        "gate": {
            "passed": gate_ok,
            "checks": [
                {
                    "name": "success_rate",
                    "passed": gate_ok,
                    "value": overall["rates"]["success"]["rate"],
                    "threshold": 0.8,
                },
                {"name": "mean_min_clearance", "passed": True, "value": 0.5, "threshold": 0.25},
            ],
        },
        "artifacts": {"summary": "evaluation.json", "episodes": "episodes.jsonl"},
        "wall_s": 12.3,
        "config": {},
    }


def dataset_summary(samples: int, episodes: int) -> dict[str, Any]:
    """A dataset's summary (core.predict.quality.summarize) with round numbers."""
    return {
        "samples": samples,
        "episodes": episodes,
        "samples_per_split": {"train": samples, "val": 0, "test": 0},
        "episodes_per_split": {"train": episodes, "val": 0, "test": 0},
        "active_agent_ratio": 0.5,
        "active_target_ratio": 0.9,
        "target_std_m": 1.0,
        "final_displacement_m": {"mean": 1.0, "p50": 1.0, "p95": 2.0},
    }


def diagnostics(episodes: int, solved: int) -> dict[str, Any]:
    """A diagnostics result without seeds (the counts and provenance only)."""
    return {
        "episodes": episodes,
        "solved": solved,
        "outcomes": {"success": solved, "timeout": episodes - solved},
        "taxonomy": taxonomy(timeout_freeze=episodes - solved),
        "taxonomy_config": {},
        "seeds": [],
        "planner": {
            "name": "predictive",
            "variant": None,
            "config": {},
            "config_hash": "c0ffee",
            "model_id": "m-7",
            "checkpoint_sha256": "deadbeef" * 8,
        },
        "code_version": "0.1.0+test",
        "artifacts": {"summary": "diagnostics.json"},
        "wall_s": 3.0,
        "config": {},
    }


def suite(success: int, n: int, clearance: float, tax: dict[str, int]) -> dict[str, Any]:
    return {
        "episodes": n,
        "success": rate_d(success, n),
        "collision": rate_d(n - success, n),
        "mean_min_clearance": mean_d([clearance] * n),
        "mean_min_distance": mean_d([clearance + 0.7] * n),
        "mean_avg_speed": mean_d([0.9] * n),
        "taxonomy": tax,
    }


def cell(variant: str, hard: int, glob: int, clr: float, tax: dict[str, int]) -> dict[str, Any]:
    return {
        "format": "foresight.campaign_cell/1",
        "key": f"{variant}__cv",
        "fingerprint": "f",
        "checkpoint": "cv",
        "variant": variant,
        "planner": {
            "name": "predictive",
            "variant": variant,
            "config": {},
            "config_hash": f"hash{variant}" * 3,
            "model_id": "cv",
            "checkpoint_sha256": "cv",
        },
        "hard": suite(hard, 4, clr, tax),
        "global": suite(glob, 20, clr + 0.2, taxonomy()),
        "integrity": {"ok": True, "checks": [], "violations": []},
        "ranking_key": [1, hard / 4, glob / 20],
        "episodes_file": f"cells/{variant}__cv.jsonl",
    }


def campaign(gate_passed: bool = False) -> dict[str, Any]:
    cells = [
        cell("careful", 3, 17, 0.45, taxonomy(timeout_freeze=1)),
        cell("base", 2, 16, 0.35, taxonomy(collision_pedestrian_robot_fault=2)),
        cell("fast", 1, 15, 0.25, taxonomy(collision_pedestrian_robot_fault=2, collision_static=1)),
    ]
    gate = {
        "passed": gate_passed,
        "candidate": "careful__cv",
        "baseline": "base__cv",
        "checks": [
            {"name": "global_success_delta", "passed": True, "value": 0.05, "threshold": 0.0},
            {
                "name": "hard_new_failure_labels",
                "passed": gate_passed,
                "value": 1.0,
                "threshold": 0.0,
                "detail": "timeout_freeze",
            },
        ],
        "hard_taxonomy": {
            "candidate": taxonomy(timeout_freeze=1),
            "baseline": taxonomy(collision_pedestrian_robot_fault=2),
            "delta": {"timeout_freeze": 1, "collision_pedestrian_robot_fault": -2},
            "new_labels": ["timeout_freeze"],
        },
    }
    return {
        "status": "passed" if gate_passed else "failed_gate",
        "exit_code": 0 if gate_passed else 2,
        "best": cells[0],
        "ranked": cells,
        "gate": gate,
        "cells_run": 3,
        "cells_resumed": 0,
        "matrix": "scenarios/classic_interactions.yaml",
        "seed_manifest": "seeds/eval_hard.yaml",
        "grid": "inline",
        "horizon": "scenario",
        "hard_episodes": 4,
        "global_episodes": 20,
        "code_version": "0.1.0+test",
        "artifacts": {"summary": "campaign_summary.json", "cells": "cells/"},
        "wall_s": 99.0,
        "best_vs_reference": {},
        "config": {},
    }


def training(proxy: bool = True) -> dict[str, Any]:
    hist = []
    for e in range(1, 7):
        rec = {
            "epoch": e,
            "train_loss": 0.5 / e,
            "val_loss": 0.6 / e,
            "train_ade": 0.6 / e + 0.1,
            "val_ade": 0.7 / e + 0.15,
            "train_fde": 1.2 / e + 0.2,
            "val_fde": 1.4 / e + 0.3,
            "cv_val_ade": 0.41,
            "cv_val_fde": 0.93,
        }
        if proxy and e % 2 == 0:
            rec["proxy"] = {"success": 0.2 * e / 2, "clearance": 0.3 + 0.01 * e}
        hist.append(rec)
    best = hist[5]
    return {
        "artifact_role": "predictive_training_summary",
        "config": {"epochs": 6},
        "dataset": {"id": "ds-1", "sha256": "0123abcd" * 8, "source": "simulator"},
        "dataset_stats": {"samples": 4321, "episodes": 40},
        "cv_val": {"ade": 0.41, "fde": 0.93},
        "history": hist,
        "best": best,
        "selection": {
            "proxy_enabled": proxy,
            "mode": "proxy" if proxy else "val_loss",
            "proxy_history": [],
            "reason": "best (proxy success, proxy clearance, -val loss)",
        },
        "selection_mode": "proxy" if proxy else "val_loss",
        "quality_gates": {
            "limits": {"max_val_ade": 1.0, "max_val_fde": 1.8},
            "cv": {"ade": 0.41, "fde": 0.93},
            "checks": {
                "val_ade_below_limit": True,
                "val_fde_below_limit": True,
                "val_ade_below_cv": True,
                "val_fde_below_cv": True,
            },
            "passed": True,
        },
        "checkpoint": "model.pt",
        "total_runtime_s": 42.0,
        "code_version": "0.1.0+test",
    }


def record(
    trace: Any, scenario: str, seed: int, *, collision_step: int, collision_point: tuple[float, float]
) -> Any:
    """The EpisodeRecord of a hand-built collided episode (core.evaluation.record.build_record)."""
    from foresight.core.evaluation.metrics import EpisodeGeometry
    from foresight.core.evaluation.record import Provenance, build_record

    geom = EpisodeGeometry(
        robot_radius=1.0, ped_radius=0.4, horizon=trace.steps, route=trace.robot[[0, -1], :2]
    )
    prov = Provenance(
        scenario=scenario,
        archetype=scenario.rsplit("_", 1)[0],
        seed=seed,
        planner="predictive",
        planner_config_hash="c0ffee",
        model_id="m-7",
        checkpoint_sha256="deadbeef" * 8,
        code_version="0.1.0+test",
        dt=trace.dt,
        horizon=trace.steps,
    )
    return build_record(
        trace,
        geom,
        outcome="collision_pedestrian",
        provenance=prov,
        collision_kind="pedestrian",
        collision_step=collision_step,
        collision_point=collision_point,
    )


def assert_picture(path: Path, min_bytes: int = 2000) -> None:
    """The file exists, is a real image and is not a blank canvas."""
    assert path.is_file() and path.stat().st_size >= min_bytes, path
    with Image.open(path) as im:
        px = np.asarray(im.convert("L"), dtype=float)
    assert px.std() > 5.0, f"{path} looks blank"


def assert_page(html: str) -> None:
    """Self-contained: no remote references, no scripts."""
    low = html.lower()
    assert "http://" not in low and "https://" not in low and "<script" not in low and "//cdn" not in low
