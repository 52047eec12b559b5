"""Hostile requests against a real ``foresight serve`` (uvicorn, SQLite file): each is refused with a 4xx naming
the field, stores nothing, keeps the connection open, and no list or page breaks afterwards. NUL bytes, which
only PostgreSQL refuses, run against a real PostgreSQL at the end."""

from __future__ import annotations

import hashlib
import io
import json
import stat
import time
import zipfile
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from sqlalchemy import insert

from foresight.store import folders, job_reads, queue
from foresight.store.models import Campaign, Dataset, Model
from foresight.store.session import make_engine
from foresight.store.settings import REPO_ROOT

from .service import Service

CHECKPOINT = (REPO_ROOT / "model" / "predictor-sim-default.pt").read_bytes()
CAMPAIGN = {"kind": "campaign", "seed_manifest": "seeds/classic_eval_hard_smoke.yaml"}
LISTS = [
    "/v1/jobs",
    "/v1/models",
    "/v1/evaluations",
    "/v1/campaigns",
    "/v1/datasets",
    "/v1/bundles",
    "/ui/jobs",
    "/ui/models",
    "/ui/results",
    "/ui/bundles",
]


class Svc:
    def __init__(self, tmp: Path, database_url: str | None = None):
        self.service = Service(tmp, database_url)
        self.service.migrate()
        self.service.serve()
        self.http = self.service.client()
        self.store = tmp / "data" / "store"
        self.engine = make_engine(database_url or f"sqlite:///{tmp / 'data' / 'foresight.db'}")

    def raw(self, path: str, body: str) -> httpx.Response:
        """POST a JSON text as written (``\\ud800`` escapes survive; httpx's json= would refuse them)."""
        return self.http.post(path, content=body.encode(), headers={"Content-Type": "application/json"})

    def counts(self) -> tuple[int, int]:
        return self.http.get("/v1/jobs").json()["count"], self.http.get("/v1/models").json()["count"]

    def lists_answer(self) -> None:
        for path in LISTS:
            r = self.http.get(path)
            assert r.status_code == 200, (path, r.status_code, r.text[:300])

    def finished_job(self, artifact: str = "model.pt", content: bytes = CHECKPOINT) -> str:
        """A succeeded job whose folder holds ``artifact`` (the shipped checkpoint: registration loads it)."""
        job, _ = queue.submit(self.engine, kind="sleep", spec={"kind": "sleep"})
        claimed = queue.claim_id(self.engine, job["id"], "test", 30)
        rel = f"{folders.job_dir(self.store, job['id'])}/{artifact}"
        folders.write_atomic(folders.resolve_under(self.store, rel), content)
        queue.finish(
            self.engine,
            job["id"],
            "test",
            claimed["attempts"],
            {},
            folders.scan(self.store, folders.job_dir(self.store, job["id"])),
        )
        return job["id"]

    def stop(self) -> None:
        self.http.close()
        self.engine.dispose()
        self.service.stop()


@pytest.fixture(scope="module")
def svc(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Svc]:
    s = Svc(tmp_path_factory.mktemp("hostile"))
    yield s
    s.stop()


def _locs(r: httpx.Response) -> list[list]:
    return [e["loc"] for e in r.json()["detail"]]


def test_a_lone_surrogate_is_refused_naming_the_field_and_stores_nothing(svc: Svc) -> None:
    before = svc.counts()
    job = {"spec": {**CAMPAIGN, "variants": [{"name": "v", "params": {"a": "\\ud800"}}]}}
    r = svc.raw("/v1/jobs", json.dumps(job).replace("\\\\ud800", "\\ud800"))
    assert r.status_code == 422, r.text
    assert ["body", "spec", "variants", 0, "params", "a"] in _locs(r)
    r = svc.raw(
        "/v1/models", '{"id": "m", "job_id": "j", "artifact": "model.pt", "metrics": {"x": "\\ud800"}}'
    )
    assert r.status_code == 422 and ["body", "metrics", "x"] in _locs(r), r.text
    r = svc.raw("/v1/jobs", '{"spec": {"kind": "sleep"}, "name": "a\\udfffb"}')
    assert r.status_code == 422 and ["body", "name"] in _locs(r), r.text
    echoed = svc.raw("/v1/jobs", '{"spec": {"kind": "\\ud800"}}')  # pydantic's error would echo the input
    assert echoed.status_code == 422 and "surrogate" in echoed.text, echoed.text
    assert echoed.headers.get("connection") != "close"  # a 500 while encoding dropped the connection
    assert svc.counts() == before
    svc.lists_answer()


def test_no_stored_value_breaks_a_listing(svc: Svc) -> None:
    """Text no request can send any more, written by another writer (a worker's result, a stage's spec)."""
    job, _ = queue.submit(svc.engine, kind="sleep", spec={"kind": "sleep", "x": "a\ud800b\x00c"})
    assert job_reads.get_job(svc.engine, job["id"])["spec"]["x"] == "a\\ud800b\\x00c"
    svc.lists_answer()
    assert svc.http.get(f"/v1/jobs/{job['id']}").status_code == 200
    assert svc.http.get(f"/ui/jobs/{job['id']}").status_code == 200
    assert svc.service.cli("jobs", "ls").returncode == 0


def test_reserved_model_ids_are_refused_and_the_default_rule_wins(svc: Svc) -> None:
    job_id = svc.finished_job()
    for ident in ("default", "cv", "none", "Default"):
        r = svc.http.post("/v1/models", json={"id": ident, "job_id": job_id, "artifact": "model.pt"})
        assert r.status_code == 422 and "reserved" in r.text and ["body", "id"] in _locs(r), (ident, r.text)
    plugin = svc.http.post(
        "/v1/models/predictors", params={"id": "default", "kind": "external", "predictor": "x"}
    )
    assert plugin.status_code == 422 and "reserved" in plugin.text, plugin.text
    ids = [m["id"] for m in svc.http.get("/v1/models").json()["data"]]
    assert not {"default", "cv", "none", "Default"} & set(ids)
    # a row that took the id before it was reserved no longer shadows the rule
    from foresight.store.registry import Resolver
    from foresight.store.settings import Settings

    with svc.engine.begin() as conn:
        conn.execute(
            insert(Model.__table__).values(
                id="default",
                status="candidate",
                checkpoint=f"jobs/{job_id}/model.pt",
                sha256=hashlib.sha256(CHECKPOINT).hexdigest(),
                time_base={},
                lineage={},
                training={},
                metrics={},
                tags=[],
                provenance="",
                read_only=False,
                job_id=job_id,
                created_at=time.time(),
            )
        )
    settings = Settings(data_dir=svc.store.parent, database_url=str(svc.engine.url))
    assert Resolver(settings, svc.engine).model_row("default").id == "predictor-sim-default"


def test_model_registration_is_bounded_and_takes_the_checkpoints_time_base(svc: Svc) -> None:
    job_id = svc.finished_job()
    base = {"job_id": job_id, "artifact": "model.pt"}
    before = svc.counts()
    for body in (
        '"metrics": {"x": NaN}',
        '"training": {"lr": Infinity}',
        '"lineage": {"n": -Infinity}',
        '"metrics": {"big": 99999999999999999999}',
    ):
        r = svc.raw("/v1/models", f'{{"id": "m-bad", "job_id": "{job_id}", "artifact": "model.pt", {body}}}')
        assert r.status_code == 422, (body, r.text)
    huge = {"id": "m-huge", **base, "metrics": {f"k{i}": "x" * 100 for i in range(1000)}}  # ~110 kB
    assert svc.http.post("/v1/models", json=huge).status_code == 413
    wrong = {"id": "m-tb", **base, "time_base": {"dt": -1, "history": 10**9, "horizon": 1}}
    r = svc.http.post("/v1/models", json=wrong)
    assert r.status_code == 422 and "time_base" in r.text, r.text
    assert svc.counts() == before
    made = svc.http.post("/v1/models", json={"id": "m-ok", **base})
    assert made.status_code == 201, made.text
    assert set(made.json()["time_base"]) == {"dt", "history", "horizon"}  # the checkpoint's, not {}
    same = svc.http.post("/v1/models", json={"id": "m-ok2", **base, "time_base": made.json()["time_base"]})
    assert same.status_code == 201, same.text


def _campaign_row(svc: Svc) -> str:
    ident = "c" * 32
    with svc.engine.begin() as conn:
        conn.execute(
            insert(Campaign.__table__).values(
                id=ident, job_id=None, config={}, best=None, created_at=time.time()
            )
        )
    return ident


def test_integers_beyond_64_bits_and_long_names_are_422_not_500(svc: Svc) -> None:
    campaign = _campaign_row(svc)
    big = str(2**64)
    for path, params in [
        ("/v1/compare", {"a": campaign + ":1", "b": f"{campaign}:99999999999999999999"}),
        (f"/ui/campaigns/{campaign}/cells/{big}", {}),
        ("/ui/jobs", {"offset": big}),
        (f"/v1/campaigns/{campaign}/cells/{big}/episodes", {}),
        (f"/v1/evaluations/{campaign}/episodes/s/{big}", {}),
    ]:
        r = svc.http.get(path, params=params)
        assert r.status_code in (404, 422), (path, r.status_code, r.text[:200])
        assert r.headers.get("connection") != "close"
    long = "a" * 300 + ".yaml"
    for spec in (
        {**CAMPAIGN, "seed_manifest": long, "variants": []},
        {**CAMPAIGN, "grid": long},
        {**CAMPAIGN, "matrix": long, "variants": []},
        {"kind": "collect", "hard_seeds": long},
        {"kind": "evaluate", "seed_manifest": f"x/{long}"},
    ):
        r = svc.http.post("/v1/jobs", json={"spec": spec})
        assert r.status_code == 422 and "255 bytes" in r.text, (spec, r.text[:300])


def test_bundle_member_names_clash_or_overrun_with_a_422(svc: Svc) -> None:
    def archive(*names: str) -> bytes:
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w") as z:
            for name in names:
                z.writestr(name, "scenarios: []\n")
        return buf.getvalue()

    for names, words in [
        (("maps/c.yaml", "maps/c.yaml/d.yaml"), "both a file and the folder"),
        ((f"maps/{'b' * 300}.yaml",), "over 255 bytes"),
    ]:
        r = svc.http.post(
            "/v1/bundles",
            params={"name": "clash"},
            content=archive(*names),
            headers={"Content-Type": "application/zip"},
        )
        assert r.status_code == 422 and words in r.text, r.text
    assert "clash" not in [b["id"] for b in svc.http.get("/v1/bundles").json()["data"]]


def _peak_rss(pid: int, *, reset: bool = False) -> int:
    """[bytes] the process's peak resident memory (Linux); ``reset`` starts a new peak at its current size."""
    if reset:
        Path(f"/proc/{pid}/clear_refs").write_text("5")
    line = next(li for li in Path(f"/proc/{pid}/status").read_text().splitlines() if li.startswith("VmHWM:"))
    return int(line.split()[1]) * 1024


def test_a_million_key_yaml_bundle_is_refused_fast_and_small(svc: Svc) -> None:
    """The probe's 10.9 MB flat YAML (2.2 MB zipped): 84 s of CPU and 1.5 GB before its refusal."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("scenarios/flat.yaml", "".join(f"k{i}: {i}\n" for i in range(1_000_000)))
    pid = svc.service.procs[0].pid
    peak = _peak_rss(pid, reset=True)
    t0 = time.monotonic()
    r = svc.http.post(
        "/v1/bundles",
        params={"name": "flat"},
        content=buf.getvalue(),
        headers={"Content-Type": "application/zip"},
    )
    took = time.monotonic() - t0
    assert r.status_code == 422 and "flat.yaml" in r.text, r.text
    assert took < 2.0 and _peak_rss(pid) - peak < 100 << 20, (took, _peak_rss(pid) - peak)


def test_422_messages_show_no_server_paths(svc: Svc) -> None:
    import tempfile

    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("scenarios/m.yaml", "scenarios:\n  - name: a\n    map_file: nope.svg\n    seeds: [1]\n")
    answers = [
        svc.http.post("/v1/bundles", params={"name": "nomap"}, content=buf.getvalue()),
        svc.http.post("/v1/jobs", json={"spec": {"kind": "evaluate", "matrix": "scenarios/missing.yaml"}}),
    ]
    for r in answers:
        assert r.status_code in (404, 422) and ("nope.svg" in r.text or "missing.yaml" in r.text), r.text
        for server_path in (tempfile.gettempdir() + "/", str(REPO_ROOT), str(svc.store.parent)):
            assert server_path not in r.text, (server_path, r.text)


def test_campaign_variants_and_bundle_files_are_checked_at_submission(svc: Svc) -> None:
    before = svc.counts()
    for params, words in [
        ({"no_such_key": 1}, "no_such_key"),
        ({"predictive_goal_weight": "NaN"}, "goal_weight"),
    ]:
        spec = {**CAMPAIGN, "variants": [{"name": "v", "params": params}]}
        r = svc.http.post("/v1/jobs", json={"spec": spec})
        assert r.status_code == 422 and words in r.text, r.text
    r = svc.http.post(
        "/v1/jobs", json={"spec": {"kind": "collect", "evaluation_seeds": "seeds/missing.yaml"}}
    )
    assert r.status_code == 404 and "evaluation_seeds" in r.text, r.text
    r = svc.http.post("/v1/jobs", json={"spec": {"kind": "evaluate", "matrix": "scenarios/missing.yaml"}})
    assert r.status_code in (404, 422) and "/work" not in r.text and str(REPO_ROOT) not in r.text, r.text
    assert svc.counts() == before


def test_a_dataset_is_checked_against_its_recorded_hash(svc: Svc) -> None:
    job_id = svc.finished_job("dataset.npz", b"original")
    with svc.engine.begin() as conn:
        conn.execute(
            insert(Dataset.__table__).values(
                id="ds1",
                job_id=job_id,
                path=f"jobs/{job_id}/dataset.npz",
                summary={},
                created_at=time.time(),
                sha256=hashlib.sha256(b"original").hexdigest(),
            )
        )
    (svc.store / "jobs" / job_id / "dataset.npz").write_bytes(b"rewritten")
    r = svc.http.post("/v1/jobs", json={"spec": {"kind": "train", "dataset": "ds1"}})
    assert r.status_code == 422 and "sha256" in r.text, r.text


def test_the_dashboard_404s_missing_episodes_and_422s_junk_parameters(svc: Svc) -> None:
    job_id = svc.finished_job("x.txt", b"x")
    assert svc.http.get(f"/ui/evaluations/{job_id}/episodes/crossing_low/1").status_code == 404
    assert svc.http.get("/ui/jobs", params={"zzz": "1"}).status_code == 422
    assert svc.http.get("/ui/models", params={"junk": "x"}).status_code == 422
    assert svc.http.get("/ui/jobs").status_code == 200


def test_the_sqlite_file_is_private_and_gc_sees_a_killed_trainings_temporaries(svc: Svc) -> None:
    mode = stat.S_IMODE((svc.store.parent / "foresight.db").stat().st_mode)
    assert mode == 0o600, oct(mode)
    job, _ = queue.submit(svc.engine, kind="sleep", spec={"kind": "sleep"})
    claimed = queue.claim_id(svc.engine, job["id"], "test", 30)
    tmp = svc.store / "jobs" / job["id"] / "checkpoints" / ".last.pt.1a2b3c4d.tmp"
    tmp.parent.mkdir(parents=True)
    tmp.write_bytes(b"half a checkpoint")
    assert ".last.pt" not in svc.service.cli("store", "gc", "--dry-run").stdout  # its job still runs
    queue.fail_or_retry(svc.engine, job["id"], "test", claimed["attempts"], "Killed", "killed", retry=False)
    listed = svc.service.cli("store", "gc", "--dry-run").stdout
    assert f"jobs/{job['id']}/checkpoints/.last.pt.1a2b3c4d.tmp" in listed, listed


def test_nul_bytes_are_422_on_postgres(tmp_path: Path, pg_url: str) -> None:
    svc = Svc(tmp_path, pg_url)
    try:
        for path, params in [
            ("/v1/jobs", {"name": "a\x00"}),
            ("/v1/jobs", {"q": "\x00"}),
            ("/v1/evaluations", {"planner": "a\x00b"}),
            ("/v1/evaluations", {"matrix": "\x00"}),
            ("/v1/campaigns", {"model": "\x00"}),
            ("/ui/jobs", {"q": "x\x00"}),
        ]:
            r = svc.http.get(path, params=params)
            assert r.status_code == 422 and "NUL" in r.text, (path, params, r.status_code, r.text[:200])
        job_id = svc.finished_job()
        body = {"id": "m-nul", "job_id": job_id, "artifact": "model.pt", "provenance": "from\x00here"}
        r = svc.http.post("/v1/models", json=body)
        assert r.status_code == 422 and ["body", "provenance"] in _locs(r), r.text
        r = svc.http.post("/v1/jobs", json={"spec": {"kind": "sleep"}, "note": "a\x00b"})
        assert r.status_code == 422, r.text
        job, _ = queue.submit(
            svc.engine, kind="sleep", spec={"kind": "sleep", "x": "a\x00b"}
        )  # another writer
        svc.lists_answer()
        assert svc.http.get(f"/v1/jobs/{job['id']}").json()["spec"]["x"] == "a\\x00b"
    finally:
        svc.stop()
