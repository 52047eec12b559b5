"""The evaluation stage end to end on a tiny slice of our own matrix (short horizon)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from pydantic import ValidationError

from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.evaluation.config import EvaluationConfig
from foresight.core.evaluation.runner import expand_seeds, read_records, run_evaluation
from foresight.core.runtime.context import Cancelled, StageContext
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT


def _ctx(tmp: Path, workers: int = 1, **kw) -> StageContext:
    tmp.mkdir(parents=True, exist_ok=True)
    return StageContext(workdir=tmp, resolve_bundle=lambda _b: BUILTIN_CONFIG_ROOT, workers=workers, **kw)


def _config(**kw) -> EvaluationConfig:
    base = dict(
        scenarios=["crossing_low", "head_on_corridor_high"],
        seeds_per_scenario=2,
        max_steps=40,
        planner={"name": "goal"},
    )
    base.update(kw)
    return EvaluationConfig.model_validate(base)


def test_expand_seeds_is_a_superset_of_the_matrix_seeds() -> None:
    assert expand_seeds((101, 102, 103), None) == [101, 102, 103]
    assert expand_seeds((101, 102, 103), 5) == [101, 102, 103, 104, 105]
    assert expand_seeds((101, 102, 103), 2) == [101, 102]


def test_results_identical_with_one_and_two_workers(tmp_path: Path) -> None:
    one = run_evaluation(_config(), _ctx(tmp_path / "w1", 1))
    two = run_evaluation(_config(), _ctx(tmp_path / "w2", 2))
    r1 = read_records(tmp_path / "w1" / "episodes.jsonl")
    r2 = read_records(tmp_path / "w2" / "episodes.jsonl")
    assert len(r1) == 4
    assert [r.comparable() for r in r1] == [r.comparable() for r in r2]
    assert one.success_rate == two.success_rate and one.taxonomy == two.taxonomy


def test_evaluation_artifacts_and_provenance(tmp_path: Path) -> None:
    seen: list[float] = []
    ctx = _ctx(tmp_path, progress=lambda f, m: seen.append(f))
    res = run_evaluation(_config(), ctx)
    data = json.loads((tmp_path / "evaluation.json").read_text())
    assert {"success_rate", "collision_rate", "status", "exit_code", "gate", "integrity"} <= set(data)
    assert data["planner"]["config"] and data["planner"]["config_hash"] == res.planner.config_hash
    assert data["taxonomy_config"]["freeze_min_s"] == 3.0
    recs = read_records(tmp_path / "episodes.jsonl")
    assert len(recs) == res.episodes == 4
    assert [(r.scenario, r.seed) for r in recs] == sorted(
        {(r.scenario, r.seed) for r in recs}, key=lambda p: (p[0] != "crossing_low", p[1])
    )
    assert all(r.provenance.horizon == 40 and r.provenance.model_id == "none" for r in recs)
    assert res.integrity.ok
    assert seen[-1] == 1.0
    assert res.exit_code in (0, 2) and (res.exit_code == 0) == res.gate.passed


def test_cancellation_stops_the_run(tmp_path: Path) -> None:
    with pytest.raises(Cancelled):
        run_evaluation(_config(), _ctx(tmp_path, is_cancelled=lambda: True))


def test_unknown_model_fails_before_any_episode(tmp_path: Path) -> None:
    ctx = _ctx(tmp_path)  # no model store: every id is unknown
    with pytest.raises(NotFoundError):
        run_evaluation(_config(planner={"name": "predictive", "model": "nope"}), ctx)
    assert not (tmp_path / "episodes.jsonl").exists()


def test_unreadable_checkpoint_fails_before_any_episode(tmp_path: Path) -> None:
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a checkpoint")
    ctx = _ctx(tmp_path / "run", resolve_model=lambda _i: bad)
    with pytest.raises(ConfigError):
        run_evaluation(_config(planner={"name": "predictive", "model": "m1"}), ctx)
    assert not (tmp_path / "run" / "episodes.jsonl").exists()


def test_bad_planner_key_is_a_config_error() -> None:
    """Caught by the config itself (the typed planner union), before any run, naming the field."""
    with pytest.raises(ValidationError, match=r"planner\.predictive\.config\.nope"):
        _config(planner={"name": "predictive", "model": "cv", "config": {"nope": 1}})


def _checkpoint(path: Path) -> Path:
    from foresight.core.predict.nn.checkpoint import make_checkpoint, save_checkpoint
    from foresight.core.predict.nn.model import ModelConfig, TrajectoryModel
    from foresight.core.predict.timebase import PLANNER_TIMEBASE as TB

    model = TrajectoryModel(ModelConfig(history=TB.history, horizon=TB.horizon, dt=TB.dt, hidden=8, blocks=1))
    save_checkpoint(make_checkpoint(model, TB, "robot", {"id": "test"}, {}, 0), path)
    return path


def test_learned_model_provenance_and_no_fallback(tmp_path: Path) -> None:
    from foresight.core.evaluation.plannerspec import sha256_file

    ckpt = _checkpoint(tmp_path / "m.pt")
    ctx = _ctx(tmp_path / "run", resolve_model=lambda _i: ckpt)
    cfg = _config(
        scenarios=["crossing_high"],
        seeds_per_scenario=1,
        max_steps=8,
        planner={"name": "predictive", "model": "m1"},
    )
    res = run_evaluation(cfg, ctx)
    (rec,) = read_records(tmp_path / "run" / "episodes.jsonl")
    assert rec.provenance.model_id == "m1" and rec.provenance.checkpoint_sha256 == sha256_file(ckpt)
    assert rec.provenance.fallback is None and res.integrity.ok
    assert res.planner.model_id == "m1"


def test_fallback_to_constant_velocity_is_flagged() -> None:
    from foresight.core.evaluation.episode import fallback_of
    from foresight.core.evaluation.plannerspec import ResolvedPlanner

    learned = ResolvedPlanner("predictive", None, {}, "h", "m1", "sha", model_path="/x.pt")
    cv = ResolvedPlanner("predictive", None, {}, "h", "cv", "cv")
    assert fallback_of(learned, {"learned:m", "constant_velocity"})
    assert fallback_of(learned, {"learned+cv_far:m"}) is None  # far pedestrians on cv is declared, not silent
    assert fallback_of(cv, {"constant_velocity"}) is None


def test_two_evaluations_at_once_in_one_process_match_their_solo_runs(tmp_path: Path) -> None:
    """Two in-process runs on threads (as a worker's slot threads run jobs) keep their own matrix, horizon and
    simulator: each run's records equal its solo run's, record for record. The runs alternate episode by episode
    (a barrier in their progress callbacks), so a run sharing state with the other would see the other's."""
    import threading

    configs = {
        "a": _config(),
        "b": _config(
            scenarios=["overtaking_medium", "crossing_high"], max_steps=25, planner={"name": "social_force"}
        ),
    }
    solo = {k: run_evaluation(cfg, _ctx(tmp_path / f"solo_{k}")) for k, cfg in configs.items()}
    barrier = threading.Barrier(2, timeout=120)
    errors: list[BaseException] = []

    def run(key: str) -> None:
        try:
            run_evaluation(
                configs[key], _ctx(tmp_path / f"both_{key}", progress=lambda _f, _m: barrier.wait())
            )
        except BaseException as exc:  # noqa: BLE001 - reported by the main thread
            errors.append(exc)
            barrier.abort()

    threads = [threading.Thread(target=run, args=(k,)) for k in configs]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    for key in configs:
        alone = read_records(tmp_path / f"solo_{key}" / "episodes.jsonl")
        together = read_records(tmp_path / f"both_{key}" / "episodes.jsonl")
        assert len(alone) == solo[key].episodes == 4
        assert [r.comparable() for r in together] == [r.comparable() for r in alone]
    horizons = {
        k: {r.provenance.horizon for r in read_records(tmp_path / f"both_{k}" / "episodes.jsonl")}
        for k in configs
    }
    assert horizons == {"a": {40}, "b": {25}}
