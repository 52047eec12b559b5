"""A worker resolves a spec's inputs by id or data-root name only: a file path in a spec is never read."""

from __future__ import annotations

import time
from pathlib import Path

from foresight.store import job_reads, queue


def _finish(engine, spec: dict, timeout: float = 120.0) -> dict:  # noqa: ANN001
    job_id = queue.submit(engine, kind=spec["kind"], spec=spec)[0]["id"]
    deadline = time.time() + timeout
    while time.time() < deadline:
        job = job_reads.get_job(engine, job_id)
        if job["status"] in ("succeeded", "failed"):
            return job
        time.sleep(0.05)
    raise AssertionError(f"job {job_id} still {job['status']}")


def test_a_dataset_path_is_an_unknown_id_not_a_file(engine, start_worker, tmp_path: Path) -> None:  # noqa: ANN001
    start_worker()
    planted = tmp_path / "planted.npz"
    planted.write_bytes(b"not a dataset")  # in-process runs would open it; a worker must not
    job = _finish(engine, {"kind": "predict_eval", "model": "cv", "dataset": str(planted)})
    assert job["status"] == "failed" and job["error_type"] == "NotFoundError", job
    assert f"unknown dataset id {str(planted)!r}" in job["error_message"]


def test_ethucy_is_a_named_data_root(engine, start_worker, shared_dir: Path) -> None:  # noqa: ANN001
    start_worker(data_roots=f"real={shared_dir / 'reference' / 'ethucy'}")
    job = _finish(engine, {"kind": "predict_eval", "model": "cv", "ethucy": "real", "folds": ["zara1"]})
    assert job["status"] == "succeeded", job
    zara1 = job["result"]["folds"]["zara1"]
    assert zara1["samples"] > 1000 and abs(zara1["ade"] - zara1["cv_ade"]) < 1e-9  # CV scored against itself

    unknown = _finish(
        engine, {"kind": "predict_eval", "model": "cv", "ethucy": str(shared_dir / "reference" / "ethucy")}
    )
    assert unknown["status"] == "failed" and unknown["error_type"] == "NotFoundError", unknown
    assert "unknown data root" in unknown["error_message"] and "real" in unknown["error_message"]
