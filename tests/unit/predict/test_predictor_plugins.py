"""Predictor plug-ins, four ways in (Python object, entry point, module:attr, external process), each through
evaluate, campaign and predict-eval; and every way of breaking the contract: one error naming the predictor."""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

import foresight
from foresight.core.errors import NotFoundError
from foresight.core.evaluation.campaign import run_campaign
from foresight.core.evaluation.config import CampaignConfig
from foresight.core.predict import plugins
from foresight.core.predict.dataset import save_dataset
from foresight.core.predict.ethucy import import_fold
from foresight.core.predict.external import ENV, TIMEOUT_ENV
from foresight.core.predict.forecast import PredictorError
from foresight.core.predict.timebase import ETHUCY_TIMEBASE
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from foresight.core.training.predict_eval import PredictEvalConfig, run_predict_eval
from tests.unit.predict.plugin_predictors import StraightOn

REPO = Path(__file__).resolve().parents[3]
ETHUCY = REPO.parent / "shared" / "reference" / "ethucy"
HERE = "tests.unit.predict.plugin_predictors"


@pytest.fixture()
def external(monkeypatch):
    commands = {
        "reference": [sys.executable, str(REPO / "examples" / "external_predictor.py")],
        "hangs": [sys.executable, str(Path(__file__).with_name("hanging_predictor.py"))],
    }
    monkeypatch.setenv(ENV, json.dumps(commands))
    monkeypatch.setenv(TIMEOUT_ENV, "0.5")


def _records(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]


def _evaluate(model, out: Path):
    return foresight.evaluate(
        "predictive", model=model, scenarios=["crossing_low"], seeds=1, max_steps=25, out=out
    )


@pytest.mark.parametrize(
    "model, kind",
    [
        (StraightOn(), "module"),
        ("cv_noise", "plugin"),
        (f"{HERE}:StraightOn", "module"),
        ("external:reference", "external"),
    ],
)
def test_each_route_drives_the_planner(model, kind, external, tmp_path):
    result = _evaluate(model, tmp_path)
    name = model if isinstance(model, str) else f"{HERE}:StraightOn"
    assert result.planner.model_id == name and result.planner.checkpoint_sha256.startswith(f"{kind}:")
    (rec,) = _records(tmp_path)
    assert rec["outcome"] != "error", rec.get("error")
    assert rec["steps"] > 20


def test_a_plugin_runs_a_campaign(tmp_path):
    root = tmp_path / "bundle"
    shutil.copytree(BUILTIN_CONFIG_ROOT, root)
    (root / "hard.yaml").write_text("crossing_high: [3]\n")
    cfg = CampaignConfig.model_validate(
        dict(
            bundle="t",
            seed_manifest="hard.yaml",
            scenarios=["crossing_low"],
            seeds_per_scenario=1,
            max_steps=15,
            checkpoints=["cv", "cv_noise"],
            variants=[{"name": "base", "config": {}}],
        )
    )
    work = tmp_path / "run"
    work.mkdir()
    result = run_campaign(cfg, StageContext(workdir=work, resolve_bundle=lambda _b: root))
    assert {c.checkpoint for c in result.ranked} == {"cv", "cv_noise"}
    cell = next(c for c in result.ranked if c.checkpoint == "cv_noise")
    assert cell.planner.model_id == "cv_noise" and cell.integrity.ok


@pytest.fixture(scope="module")
def hotel(tmp_path_factory) -> Path:
    ds = import_fold(ETHUCY, "hotel", ETHUCY_TIMEBASE, 12, ("test",))
    path = tmp_path_factory.mktemp("hotel") / "hotel.npz"
    save_dataset(ds.subset(np.arange(120)), path)
    return path


def _predict_eval(model: str, dataset: Path, tmp_path: Path, **kw):
    cfg = PredictEvalConfig(model=model, dataset=str(dataset), **kw)
    return run_predict_eval(cfg, StageContext(workdir=tmp_path, local_files=True))


class EthucyStraightOn(StraightOn):
    timebase = {"dt": 0.4, "history": 8, "horizon": 12}


def test_predict_eval_scores_plugins_with_the_fields_metrics(hotel, tmp_path):
    noise = _predict_eval("cv_noise", hotel, tmp_path / "a", best_of=20).folds["hotel"]
    # mode 0 is plain constant velocity: best-of-1 is exactly constant velocity's score on the same windows
    assert noise.ade == pytest.approx(noise.cv_ade, abs=1e-6) and noise.fde == pytest.approx(
        noise.cv_fde, abs=1e-6
    )
    assert (
        noise.modes == 20 and noise.best_of == 20 and noise.min_ade < noise.ade and noise.min_fde < noise.fde
    )
    assert noise.nll is not None and 0 < noise.within_1sigma <= noise.within_2sigma <= 1
    five = _predict_eval("cv_noise", hotel, tmp_path / "b", best_of=5).folds["hotel"]
    assert five.best_of == 5 and noise.min_ade <= five.min_ade
    mine = _predict_eval(f"{__name__}:EthucyStraightOn", hotel, tmp_path / "c").folds["hotel"]
    # the pedestrian frame is converted: its most likely mode is constant velocity too
    assert mine.ade == pytest.approx(mine.cv_ade, abs=1e-5) and mine.best_of == 2


def test_predict_eval_through_an_external_process(hotel, tmp_path, monkeypatch):
    script = tmp_path / "eth_cv.py"
    text = (REPO / "examples" / "external_predictor.py").read_text()
    script.write_text(
        text.replace('{"dt": 0.2, "history": 5, "horizon": 12}', '{"dt": 0.4, "history": 8, "horizon": 12}')
    )
    monkeypatch.setenv(ENV, json.dumps({"eth": [sys.executable, str(script)]}))
    r = _predict_eval("external:eth", hotel, tmp_path / "x").folds["hotel"]
    assert r.ade == pytest.approx(r.cv_ade, abs=1e-5) and r.modes == 1 and r.nll is not None


def test_predict_eval_refuses_another_time_base(hotel, tmp_path):
    with pytest.raises(PredictorError, match="straight_on.*wrong time base|StraightOn.*wrong time base"):
        _predict_eval(f"{HERE}:StraightOn", hotel, tmp_path)


@pytest.mark.parametrize(
    "model, expected",
    [
        (f"{HERE}:nan_predictor", "NaN"),
        (f"{HERE}:too_few_modes", "at least 2 expected"),
        ("external:hangs", "no answer within 0.5 s"),
    ],
)
def test_broken_predictors_end_the_episode_with_an_error_naming_them(model, expected, external, tmp_path):
    _evaluate(model, tmp_path)
    (rec,) = _records(tmp_path)
    assert rec["outcome"] == "error"
    assert f"predictor '{model}'" in rec["error"] and expected in rec["error"]


def test_unknown_predictors_are_refused_before_any_episode(external, tmp_path):
    with pytest.raises(NotFoundError, match="no_such_module"):
        _evaluate("no_such_module:Predictor", tmp_path)
    with pytest.raises(PredictorError, match="'external:nobody'.*not configured"):
        _evaluate("external:nobody", tmp_path)
    assert (
        plugins.kind("cv_noise") == "plugin"
        and plugins.kind("cv") is None
        and plugins.kind("file:x.pt") is None
    )
