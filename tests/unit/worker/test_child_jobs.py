"""The pipeline's run_child (ChildJobs) over a worker's child-job facility against a real SQLite file, with ``sleep`` children:
child rows with their parent, claimed and run in the caller's thread, resume, retry, cancellation, registry."""

from __future__ import annotations

import threading
import time

import pytest
from sqlalchemy import update

from foresight.core.errors import CoreError
from foresight.core.jobs.pipeline.config import load_pipeline_config
from foresight.core.jobs.pipeline.service import ChildJobs
from foresight.core.runtime.context import Cancelled, StageContext
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from foresight.store import folders, job_reads, queue
from foresight.store.session import write_tx
from foresight.store.settings import Settings
from foresight.worker.runner import Held, JobWorker


class Parent:
    """A claimed pipeline job row and the context its worker would give it."""

    def __init__(self, settings: Settings, engine) -> None:  # noqa: ANN001
        queue.submit(engine, kind="pipeline", spec={"kind": "pipeline"})
        self.job = queue.claim(engine, "worker-1", ["pipeline"], 30.0)
        self.cancelled = False
        workdir = folders.resolve_under(
            settings.store_root, folders.job_dir(settings.store_root, self.job["id"])
        )
        workdir.mkdir(parents=True)
        self.ctx: StageContext = JobWorker(settings, engine, worker_id="worker-1").stage_context(
            Held(self.job, None), workdir
        )
        self.ctx.is_cancelled = lambda: self.cancelled
        self.config = load_pipeline_config(BUILTIN_CONFIG_ROOT / "pipelines" / "smoke.yaml")

    def children(self) -> ChildJobs:
        return ChildJobs(self.ctx, self.config)


def _progress(seen: list) -> callable:
    return lambda fraction, message: seen.append((fraction, message))


def test_the_child_jobs_use_the_running_workers_services(settings, engine) -> None:  # noqa: ANN001
    parent = Parent(settings, engine)
    jobs = parent.ctx.children("pipeline", None)
    try:
        assert jobs.settings is settings and jobs.engine is engine and jobs.parent_id == parent.job["id"]
    finally:
        jobs.close()


def test_a_child_is_a_job_row_run_in_this_thread_and_not_run_twice(settings, engine) -> None:  # noqa: ANN001
    parent = Parent(settings, engine)
    children = parent.children()
    seen: list = []
    try:
        run = children("nap", "sleep", {"seconds": 0.2, "steps": 2, "artifact": "out.txt"}, _progress(seen))
        child = job_reads.get_job(engine, run.job_id)
        assert child["parent_id"] == parent.job["id"] and child["status"] == "succeeded"
        assert child["idempotency_key"] == f"pipeline:{parent.job['id']}:nap"
        assert child["lease_owner"].endswith("/pipeline") and not run.resumed
        assert (
            run.result == {"slept_s": 0.2} and seen and seen[-1][0] == 1.0
        )  # child progress reached the pipeline
        again = children("nap", "sleep", {"seconds": 0.2, "steps": 2, "artifact": "out.txt"}, _progress(seen))
        assert again.resumed and again.job_id == run.job_id
        assert job_reads.get_job(engine, run.job_id)["attempts"] == 1
    finally:
        children.close()


def test_a_failed_child_fails_the_stage_and_a_rerun_retries_it(settings, engine) -> None:  # noqa: ANN001
    parent = Parent(settings, engine)
    children = parent.children()
    try:
        with pytest.raises(CoreError, match="RuntimeError: boom"):
            children("bad", "sleep", {"fail": "boom"}, _progress([]))
        ok = children("fine", "sleep", {"seconds": 0.0}, _progress([]))
        with write_tx(engine) as conn:  # as if this stage had failed in the earlier run
            conn.execute(update(queue.jobs).where(queue.jobs.c.id == ok.job_id).values(status="failed"))
    finally:
        children.close()
    rerun = parent.children()
    try:
        again = rerun("fine", "sleep", {"seconds": 0.0}, _progress([]))
        assert again.job_id == ok.job_id and not again.resumed
        assert job_reads.get_job(engine, ok.job_id)["status"] == "succeeded"
    finally:
        rerun.close()


def test_cancelling_the_pipeline_cancels_the_running_child(settings, engine) -> None:  # noqa: ANN001
    parent = Parent(settings, engine)
    children = parent.children()
    outcome: list = []

    def run() -> None:
        try:
            children("long", "sleep", {"seconds": 20, "steps": 200}, _progress([]))
        except BaseException as exc:  # noqa: BLE001
            outcome.append(exc)

    thread = threading.Thread(target=run)
    thread.start()
    try:
        deadline = time.time() + 10
        while "long" not in children.children and time.time() < deadline:
            time.sleep(0.05)
        queue.request_cancel(engine, parent.job["id"])
        parent.cancelled = True
        thread.join(timeout=10)
        assert not thread.is_alive() and isinstance(outcome[0], Cancelled)
        assert job_reads.get_job(engine, children.children["long"])["status"] == "cancelled"
    finally:
        children.close()


def _make_it_a_checkpoint(settings, engine, job_id: str) -> None:  # noqa: ANN001
    """Put a real checkpoint where the sleep child wrote its text artifact, and record its checksum."""
    import hashlib

    from foresight.store.settings import REPO_ROOT

    data = (REPO_ROOT / "model" / "predictor-sim-default.pt").read_bytes()
    folders.resolve_under(settings.store_root, f"jobs/{job_id}/model.pt").write_bytes(data)
    with write_tx(engine) as conn:
        conn.execute(
            update(queue.artifacts)
            .where(queue.artifacts.c.job_id == job_id)
            .values(sha256=hashlib.sha256(data).hexdigest(), size=len(data))
        )


def test_register_then_promote_in_the_registry(settings, engine) -> None:  # noqa: ANN001
    from foresight.store.models import Model
    from foresight.store.session import session_factory

    parent = Parent(settings, engine)
    children = parent.children()
    try:
        train = children("train", "sleep", {"artifact": "model.pt"}, _progress([]))
        _make_it_a_checkpoint(settings, engine, train.job_id)  # registration checks the artifact loads
        spec = {
            "model_id": "cand-1",
            "status": "candidate",
            "train_stage": "train",
            "tags": ["pipeline"],
            "lineage": {"datasets": {"base": "x"}},
            "metrics": {"val_ade": 0.3},
            "training": {},
        }
        reg = children("register", "register", spec, _progress([]))
        assert reg.ident == "cand-1" and not reg.resumed
        assert children(
            "register", "register", spec, _progress([])
        ).resumed  # a resumed pipeline re-registers nothing
        with session_factory(engine)() as session:
            row = session.get(Model, "cand-1")
            assert (row.status, row.job_id, row.read_only) == ("candidate", train.job_id, False)
            assert row.checkpoint == f"jobs/{train.job_id}/model.pt"
        children("promote", "promote", {"model_id": "cand-1", "to": "default"}, _progress([]))
        with session_factory(engine)() as session:
            assert session.get(Model, "cand-1").status == "default"
    finally:
        children.close()


def test_a_relaxed_pipelines_model_is_registered_relaxed_and_never_promoted(settings, engine) -> None:  # noqa: ANN001
    from foresight.store.models import Model
    from foresight.store.session import session_factory

    parent = Parent(settings, engine)
    children = parent.children()
    try:
        train = children("train", "sleep", {"artifact": "model.pt"}, _progress([]))
        _make_it_a_checkpoint(settings, engine, train.job_id)
        spec = {
            "model_id": "smoke-1",
            "status": "relaxed",
            "train_stage": "train",
            "tags": [],
            "lineage": {},
            "metrics": {},
            "training": {},
        }
        children("register", "register", spec, _progress([]))
        with session_factory(engine)() as session:
            assert session.get(Model, "smoke-1").status == "relaxed"
        with pytest.raises(queue.Conflict, match="never be promoted"):
            children("promote", "promote", {"model_id": "smoke-1", "to": "default"}, _progress([]))
        children.record_promotion("smoke-1", {"promoted": False, "why": "relaxed"})
        with session_factory(engine)() as session:
            assert session.get(Model, "smoke-1").metrics["promotion"]["why"] == "relaxed"
    finally:
        children.close()


def _pipeline_result(gates: list[dict]) -> dict:
    """A failed-gate pipeline job's result with these gate verdicts."""
    from foresight.core.reports.pipeline_summary import PipelineResult, PipelineSummary

    summary = PipelineSummary(name="p", status="failed_gate", exit_code=2, stages=[], gates=gates)
    return PipelineResult(
        name="p",
        status="failed_gate",
        exit_code=2,
        passed=False,
        failed_gates=["evaluation"],
        model_id=None,
        promoted=False,
        promotion="",
        stages=[],
        summary=summary,
        artifacts={},
        wall_s=1.0,
    ).model_dump(mode="json")


def test_the_pipeline_verdict_is_recorded_as_gate_rows(settings, engine) -> None:  # noqa: ANN001
    from sqlalchemy import select

    from foresight.store.models import GateResult
    from foresight.store.records import pipeline_gates as record_gates

    parent = Parent(settings, engine)
    gates = [
        {"name": "evaluation", "passed": False, "checks": []},
        {"name": "training", "passed": True, "checks": []},
        {"name": "closed_loop", "passed": None, "checks": [], "detail": "not evaluated"},
    ]
    with write_tx(engine) as conn:
        record_gates(conn, parent.job, _pipeline_result(gates), "jobs/x")
    with engine.connect() as conn:
        rows = conn.execute(
            select(GateResult.gate, GateResult.passed).where(GateResult.job_id == parent.job["id"])
        )
        assert sorted(rows) == [("pipeline:evaluation", False), ("pipeline:training", True)]


def test_a_reference_run_is_shared_by_key_across_pipelines(settings, engine) -> None:  # noqa: ANN001
    """The incumbent's runs are cached: a second pipeline asking with the same key gets the first one's job."""
    first, second = Parent(settings, engine), Parent(settings, engine)
    spec = {"seconds": 0.1, "steps": 1, "artifact": "out.txt"}
    a, b = first.children(), second.children()
    try:
        run = a(
            "incumbent_evaluate", "sleep", spec, _progress([]), cache_key="reference:abc:incumbent_evaluate"
        )
        again = b(
            "incumbent_evaluate", "sleep", spec, _progress([]), cache_key="reference:abc:incumbent_evaluate"
        )
        assert again.job_id == run.job_id and again.resumed and run.folder == again.folder
        assert job_reads.get_job(engine, run.job_id)["attempts"] == 1
        own = b("evaluate", "sleep", spec, _progress([]))
        assert own.job_id != run.job_id  # a pipeline's own stage is never shared
    finally:
        a.close()
        b.close()


def test_the_pipeline_reads_the_registry_through_its_children(settings, engine) -> None:  # noqa: ANN001
    from foresight.store import registry
    from foresight.store.settings import REPO_ROOT
    from foresight.store.shipped import default_model, read_shipped

    shipped = REPO_ROOT / "model" / "registry.yaml"
    registry.load_shipped_models(engine, settings.model_copy(update={"model_registry": shipped}))
    parent = Parent(settings, engine)
    children = parent.children()
    try:
        assert children.model_row("no-such-model") is None
        ids = {r["id"] for r in children.model_rows()}
        default = children.model_row("default")  # the shipped default, by the registry's one rule
        want = default_model(read_shipped(shipped))
        assert default is not None and default["id"] == want["id"] and default["sha256"] == want["sha256"]
        assert default["id"] in ids
    finally:
        children.close()
