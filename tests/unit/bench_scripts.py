"""The scripts under bench/ as modules, for tests of their pure parts (they are scripts, not a package), and
``SMOKE``: how each script runs small, for the test that runs every one of them (tests/unit/test_bench_scripts.py)."""

from __future__ import annotations

import importlib.util
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

BENCH = Path(__file__).resolve().parents[2] / "bench"


def load_bench(name: str) -> ModuleType:
    """bench/<name>.py, imported."""
    spec = importlib.util.spec_from_file_location(name, BENCH / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def scripts() -> list[str]:
    """Every script under bench/ (``_*.py``: helpers, not scripts)."""
    return sorted(p.stem for p in BENCH.glob("*.py") if not p.name.startswith("_"))


@dataclass(frozen=True)
class Smoke:
    """One bench script at tiny sizes: its arguments, run from the repository root (``{work}``: a folder shared by
    the module's runs, ``{shared}``: the shared reference material), the keys its one JSON object must have, and
    what else must hold of it (``check``, given the object: a message where it fails, else None)."""

    args: tuple[str, ...]
    keys: frozenset[str]
    shared: bool = True  #: reads ../shared (skipped without it, like the tests that read it)
    after: str | None = None  #: a script whose run this one reads (run first)
    check: Callable[[dict], str | None] | None = None
    prepare: Callable[[Path, Path | None], None] | None = (
        None  #: (work, shared): writes the run's inputs first
    )


def _sim_speed(out: dict) -> str | None:
    cases = [e["case"] for e in out["entries"]]
    return (
        None
        if "open_1000" in cases and len(cases) > 2
        else f"cases {cases}: expected open_1000 and the classic"
    )


def _episodes(n: int) -> Callable[[dict], str | None]:
    return lambda out: None if out["episodes"] == n else f"{out['episodes']} episodes, expected {n}"


def _no_errors(out: dict) -> str | None:
    return f"jobs failed: {out['errors']}" if out["errors"] else None


def _tiny_ethucy(work: Path, shared: Path | None) -> None:
    """{work}/ethucy: the hotel fold with the first 400 rows of each recording (seconds, not minutes, to train)."""
    for src in sorted((shared / "reference" / "ethucy" / "hotel").glob("*/*.txt")):
        dst = work / "ethucy" / "hotel" / src.parent.name / src.name
        dst.parent.mkdir(parents=True, exist_ok=True)
        dst.write_text("".join(src.read_text().splitlines(keepends=True)[:400]))


TINY_TRAINING = json.dumps({"epochs": 1, "ensemble": 1, "hidden": 8, "blocks": 1, "batch_size": 512})
SCENARIO = "classic_doorway_low"

#: per bench script, how it runs in a few seconds; a new script under bench/ needs an entry here
SMOKE: dict[str, Smoke] = {
    "api_load": Smoke(
        ("--json", "--duration", "0.5", "--clients", "2", "--claim-jobs", "5", "--claim-workers", "1"),
        frozenset({"status_reads", "submissions", "claims", "targets", "machine", "meets_targets"}),
        shared=False,
    ),
    "ethucy_sweep": Smoke(
        (
            "--json",
            "--ethucy",
            "{work}/ethucy",
            "--folds",
            "hotel",
            "--variant",
            f"tiny={TINY_TRAINING}",
        )
        + ("--workers", "1", "--out", "{work}/ethucy_sweep"),
        frozenset({"benchmark", "folds", "table", "errors"}),
        check=_no_errors,
        prepare=_tiny_ethucy,
    ),
    "eval_throughput": Smoke(
        (
            "--json",
            "--scenarios",
            SCENARIO,
            "--seeds-per-scenario",
            "1",
            "--max-steps",
            "60",
            "--workers",
            "1",
        )
        + ("--out", "{work}/eval_throughput"),
        frozenset({"benchmark", "episodes", "wall_s", "episodes_per_s", "success_rate", "workdir"}),
        check=_episodes(1),
    ),
    "forecast_calibration": Smoke(
        ("--json", "--scenarios", "crossing_nr30", "--per-scenario", "1", "--max-steps", "60"),
        frozenset({"benchmark", "times", "predictors"}),
        shared=False,
        check=lambda out: (
            None if set(out["predictors"]) == {"constant_velocity", "learned"} else "predictors"
        ),
    ),
    "forecast_near_robot": Smoke(
        ("--json", "cv={work}/eval_throughput"),
        frozenset({"bands_m", "runs"}),
        after="eval_throughput",
        check=lambda out: None if out["runs"]["cv"]["episodes"] == 1 else "expected the one traced episode",
    ),
    "hostile_inputs": Smoke(
        (),
        frozenset({"service", "core"}),
        shared=False,
        check=lambda out: (
            None
            if out["core"]["summary"]["hostile_inputs_tried"] > 0
            and out["service"]["totals"]["requests"] > 0
            and out["service"]["totals"]["responses_500"] == 0
            and out["service"]["totals"]["stored_by_refused_requests"] == 0
            and out["service"]["totals"]["listings_broken"] == 0
            and out["service"]["totals"]["crowd_bomb_refused_at_submission"]
            and out["service"]["totals"]["million_key_yaml_refused"]
            else f"no input tried, or a hostile request answered 500 or was kept: {out['service']['totals']}"
        ),
    ),
    "paused_workers": Smoke(
        ("--runs", "2", "--epochs", "10"),
        frozenset({"runs", "overwritten", "sha_mismatch", "lost", "not_rerun", "per_kind"}),
        shared=False,
        check=lambda out: (
            None
            if out["runs"] == 2
            and out["not_rerun"] == 0
            and out["overwritten"] + out["sha_mismatch"] + out["lost"] == 0
            else f"paused-worker runs: {out}"
        ),
    ),
    "episode_export": Smoke(
        ("--json", "--episodes", "200"),
        frozenset({"episodes", "parquet_s", "csv_s", "jsonl_s", "parquet_ok"}),
        shared=False,
        check=lambda out: None if out["episodes"] == 200 and out["parquet_bytes"] > 0 else "nothing exported",
    ),
    "import_memory": Smoke(
        ("--json", "--mb", "0.1"),
        frozenset({"benchmark", "file_mb", "track_lines", "windows", "peak_rss_mb", "wall_s"}),
        shared=False,
    ),
    "make_stress_suite": Smoke(
        (
            "--out",
            "{work}/stress.yaml",
            "--train-out",
            "{work}/train.yaml",
            "--replication-out",
            "{work}/rep.yaml",
        ),
        frozenset({"matrix", "train_seeds", "replication_seeds", "scenarios", "episodes"}),
    ),
    "latency_table": Smoke(
        ("--json", "--suites", "reference", "--scenarios", SCENARIO, "--seeds-per-scenario", "1")
        + (
            "--planners",
            "predictive_cv",
            "--latencies",
            "0,0.3",
            "--workers",
            "1",
            "--out",
            "{work}/latency_table",
        ),
        frozenset({"command", "latencies", "table", "runs"}),
        check=lambda out: (
            None
            if "vs_0" in out["table"]["reference"]["predictive (cv)"]["0.3"]
            else "the latency-0.3 cell lacks its pairing with latency 0"
        ),
    ),
    "navigation_table": Smoke(
        ("--json", "--suites", "reference_defaults", "--scenarios", SCENARIO, "--seeds-per-scenario", "1")
        + ("--planners", "predictive_cv", "--workers", "1", "--out", "{work}/navigation_table"),
        frozenset({"command", "suites", "runs"}),
    ),
    "oracle_gap": Smoke(
        (
            "--json",
            "--scenarios",
            SCENARIO,
            "--seeds-per-scenario",
            "1",
            "--max-steps",
            "20",
            "--workers",
            "1",
        ),
        frozenset({"benchmark", "episodes", "forecasters", "paired"}),
        check=_episodes(1),
    ),
    "prediction_switch": Smoke(
        ("--json", "--suites", "crowdnavpp_rand", "--forecasts", "static,cv,oracle", "--episodes", "1")
        + ("--max-steps", "8", "--workers", "1"),
        frozenset({"benchmark", "suites", "planner"}),
        shared=False,
        check=lambda out: (
            None
            if {f: r["episodes"] for f, r in out["suites"]["crowdnavpp_rand"]["forecasts"].items()}
            == {"static": 1, "cv": 1, "oracle": 1}
            else f"expected one episode per forecast, got {out['suites']}"
        ),
    ),
    "planner_ab": Smoke(
        ("--json", "--variant", "a={}", "--variant", 'cv={"model": "cv"}', "--suites", "reference_defaults")
        + ("--scenarios", SCENARIO, "--seeds-per-scenario", "1", "--workers", "1"),
        frozenset({"benchmark", "suites"}),
    ),
    "planner_latency": Smoke(
        ("--json", "--pedestrians", "4", "--decisions", "5"),
        frozenset({"benchmark", "targets", "entries"}),
        shared=False,
    ),
    "predict_latency": Smoke(
        ("--json", "--repeats", "5"),
        frozenset({"median_ms", "p90_ms", "torch_median_ms", "target_ms"}),
        shared=False,
    ),
    "predictor_roundtrip": Smoke(
        ("--json", "--pedestrians", "4", "--forecasts", "5"),
        frozenset({"benchmark", "targets", "entries"}),
        shared=False,
    ),
    "real_data_closed_loop": Smoke(
        ("--json", "--fold-models", "{work}/ethucy_sweep", "--scenarios", "replay_biwi_hotel_6850")
        + ("--max-steps", "20", "--workers", "1"),
        frozenset({"benchmark", "episodes", "predictors", "paired", "ethucy_models", "episode_rows"}),
        after="ethucy_sweep",  # its tiny hotel-fold model holds biwi_hotel out
        check=_episodes(1),
    ),
    "scale_out": Smoke(
        (
            "--json",
            "--scenarios",
            SCENARIO,
            "--max-steps",
            "5",
            "--cpus",
            "1",
            "--tasks",
            "5",
            "--parts-only",
        ),
        frozenset({"matrix", "components", "local", "ray"}),
    ),
    "sim_speed": Smoke(
        ("--json", "--steps", "3", "--repeats", "1", "--sizes", "10", "1000"),
        frozenset({"entries", "cold_start_s", "classic_median_ms_per_step", "classic_max_ms_per_step"}),
        check=_sim_speed,
    ),
    "train_speed": Smoke(
        ("--json", "--batch", "4", "--agents", "3", "--seconds", "0.05"),
        frozenset({"samples_per_s", "flops_per_sample", "params"}),
        shared=False,
    ),
    "witness_plans": Smoke(
        ("--json", "--scenarios", SCENARIO, "--seeds-per-scenario", "1", "--workers", "1"),
        frozenset({"benchmark", "plans", "scenarios"}),
    ),
}
