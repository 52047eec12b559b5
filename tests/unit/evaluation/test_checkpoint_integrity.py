"""Checkpoint integrity: what a run loads is what it records; a checkpoint rewritten in place (size
and mtime restored) is refused wherever it is loaded again."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import pytest
import torch

from foresight.core.errors import ConfigError
from foresight.core.evaluation import plannerspec
from foresight.core.evaluation.plannerspec import PlannerSpec, build_planner, load_model, resolve_planner
from foresight.core.predict.nn.checkpoint import load_predictor, read_checkpoint
from foresight.core.runtime.context import StageContext

REPO = Path(__file__).resolve().parents[3]
SHIPPED = REPO / "model" / "predictor-sim-default.pt"


def _rewrite_keeping_size_and_mtime(path: Path) -> None:
    """Change the weights' bytes in place (a real, loadable checkpoint), then restore size and mtime."""
    st = path.stat()
    payload = read_checkpoint(path)
    first = next(iter(payload["model"]))
    payload["model"][first] = payload["model"][first] + 1.0
    torch.save(payload, path)
    data = path.read_bytes()
    assert len(data) == st.st_size  # same tensors, same layout: only values changed
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))


@pytest.fixture()
def checkpoint(tmp_path: Path) -> Path:
    path = tmp_path / "model.pt"
    torch.save(read_checkpoint(SHIPPED), path)  # saved under this name, so a rewrite keeps the size
    plannerspec._MODELS.clear()
    yield path
    plannerspec._MODELS.clear()


def test_the_recorded_checksum_is_that_of_the_bytes_loaded(checkpoint: Path, tmp_path: Path) -> None:
    ctx = StageContext(workdir=tmp_path, resolve_model=lambda _ident: checkpoint)
    rp = resolve_planner(PlannerSpec(name="predictive", model="m1"), ctx)
    assert rp.checkpoint_sha256 == hashlib.sha256(checkpoint.read_bytes()).hexdigest()
    assert load_predictor(checkpoint).sha256 == rp.checkpoint_sha256


def test_a_checkpoint_rewritten_after_resolution_is_refused_by_a_later_load(
    checkpoint: Path, tmp_path: Path
) -> None:
    ctx = StageContext(workdir=tmp_path, resolve_model=lambda _ident: checkpoint)
    rp = resolve_planner(PlannerSpec(name="predictive", model="m1"), ctx)
    _rewrite_keeping_size_and_mtime(checkpoint)
    plannerspec._MODELS.clear()  # what a freshly started evaluation worker process holds
    with pytest.raises(ConfigError, match="checkpoint content changed") as err:
        build_planner(rp)
    assert err.value.item == "sha256" and err.value.source == str(checkpoint)


def test_load_predictor_checks_the_expected_checksum(checkpoint: Path) -> None:
    good = hashlib.sha256(checkpoint.read_bytes()).hexdigest()
    assert load_predictor(checkpoint, expect_sha256=good).sha256 == good
    with pytest.raises(ConfigError, match="checkpoint content changed"):
        load_predictor(checkpoint, expect_sha256="0" * 64)
    assert load_model(str(checkpoint), good) is load_model(str(checkpoint), good)  # one load per process
