"""Rows an older version stored with values no reader can serve back (lone UTF-16 surrogates in JSON columns, NaN
and Infinity) never break a listing or a detail page: each is read with a replacement (the surrogate written as
the escape ``\\ud800``, NaN and Infinity as null) and every list still answers and names the row."""

from __future__ import annotations

import re
import sqlite3
import time
from pathlib import Path

from .service import Service

JOB_IDS = {"old-surrogate": "1" * 32, "old-nan": "2" * 32}
LISTS = [
    "/v1/jobs",
    "/v1/models",
    "/v1/evaluations",
    "/v1/campaigns",
    "/v1/datasets",
    "/ui/jobs",
    "/ui/models",
    "/ui/results",
]
ROWS_LISTED = {
    "/v1/models": "old-model",
    "/ui/models": "old-model",
    "/v1/evaluations": "old-eval",
    "/v1/campaigns": "old-campaign",
    "/v1/datasets": "old-dataset",
    "/ui/results": "old-nan",
}


def _old_rows() -> list[tuple[str, tuple]]:
    """(SQL, parameters) writing rows as an older version did: JSON text with lone surrogate escapes and NaN."""
    now = time.time()
    jobs = [  # (name, kind, spec, result)
        (
            "old-surrogate",
            "sleep",
            '{"kind": "sleep", "x": "a\\ud800b", "\\udfff": 1}',
            '{"note": "\\udbff"}',
        ),
        (
            "old-nan",
            "evaluate",
            '{"kind": "evaluate", "x": NaN, "y": [Infinity, -Infinity]}',
            '{"loss": NaN}',
        ),
    ]
    rows = [
        (
            "INSERT INTO jobs (id, kind, spec, status, priority, attempts, max_attempts, cancel_requested, progress,"
            " message, result, created_at, finished_at, name, tags, note) VALUES (%s, %s, %s, 'succeeded', 0, 1,"
            " 3, false, 1.0, '', %s, %s, %s, %s, %s, '')",
            (JOB_IDS[name], kind, spec, result, now, now, name, '["\\ud800"]'),
        )
        for name, kind, spec, result in jobs
    ]
    return rows + [
        (
            "INSERT INTO models (id, status, checkpoint, sha256, time_base, lineage, training, metrics, tags,"
            " provenance, read_only, job_id, created_at) VALUES ('old-model', 'candidate', 'jobs/x/model.pt', %s, '{}',"
            " '{}', %s, %s, %s, 'old', false, %s, %s)",
            (
                "0" * 64,
                '{"\\udfff": NaN}',
                '{"ade": NaN, "x": "\\ud800"}',
                '["\\ud800"]',
                JOB_IDS["old-surrogate"],
                now,
            ),
        ),
        (
            "INSERT INTO evaluations (id, job_id, config, metrics, per_scenario, created_at) VALUES ('old-eval', %s, %s,"
            " %s, '[]', %s)",
            (
                JOB_IDS["old-nan"],
                '{"stage": {"planner": "\\ud800"}, "planner": {"name": "goal", "x": NaN}}',
                '{"success_rate": NaN, "collision_rate": 0.0, "episodes": 1, "status": "\\ud800", "overall": {"key":'
                ' "global", "episodes": 1, "rates": {}, "means": {"time": {"n": 1, "mean": NaN, "low": NaN, "high":'
                ' Infinity}}, "failed": [], "taxonomy": {"\\ud800": 1}}}',
                now,
            ),
        ),
        (
            "INSERT INTO campaigns (id, job_id, config, best, created_at) VALUES ('old-campaign', %s, %s, %s, %s)",
            (
                JOB_IDS["old-nan"],
                '{"matrix": "\\ud800"}',
                '{"checkpoint": "default", "variant": "\\ud800", "global":'
                ' {"success": {"rate": NaN}, "collision": {"rate": 0.0}, "episodes": 1}}',
                now,
            ),
        ),
        (
            "INSERT INTO datasets (id, job_id, path, sha256, summary, created_at) VALUES ('old-dataset', %s,"
            " 'jobs/x/d.npz', NULL, %s, %s)",
            (JOB_IDS["old-nan"], '{"samples": NaN, "\\ud800": 1}', now),
        ),
    ]


def _check_listings(service: Service, *, nan: bool) -> None:
    with service.client() as http:
        for path in LISTS:
            r = http.get(path)
            assert r.status_code == 200, (path, r.status_code, r.text[:300])
            for row in [ROWS_LISTED.get(path, "")] if path in ROWS_LISTED else JOB_IDS.values():
                assert row in r.text or path.startswith("/ui/") and row[:8] in r.text, (
                    path,
                    row,
                    r.text[:300],
                )
        for name, job_id in JOB_IDS.items():
            for path in (f"/v1/jobs/{job_id}", f"/ui/jobs/{job_id}"):
                r = http.get(path)
                assert r.status_code == 200 and name in r.text, (path, r.status_code, r.text[:300])
        spec = http.get(f"/v1/jobs/{JOB_IDS['old-surrogate']}").json()["spec"]
        assert spec["x"] == "a\\ud800b" and spec["\\udfff"] == 1, spec
        if nan:
            assert http.get(f"/v1/jobs/{JOB_IDS['old-nan']}").json()["spec"]["y"] == [None, None]
        model = http.get("/v1/models/old-model")
        assert model.status_code == 200 and model.json()["metrics"]["x"] == "\\ud800", model.text
        assert not nan or model.json()["metrics"]["ade"] is None, model.text
    ls = service.cli("jobs", "ls")
    assert all(name in ls.stdout for name in JOB_IDS), ls.stdout


def test_rows_an_older_version_stored_never_break_a_listing(tmp_path: Path) -> None:
    service = Service(tmp_path)
    try:
        service.migrate()
        with sqlite3.connect(tmp_path / "data" / "foresight.db") as conn:
            for sql, params in _old_rows():
                conn.execute(sql.replace("%s", "?").replace("false", "0"), params)
        service.serve()
        _check_listings(service, nan=True)
    finally:
        service.stop()


def test_rows_an_older_version_stored_never_break_a_listing_on_postgresql(
    tmp_path: Path, pg_url: str
) -> None:
    """PostgreSQL's ``json`` keeps a lone surrogate escape as written (it refuses NaN: written as null there)."""
    import psycopg

    service = Service(tmp_path, database_url=pg_url)
    no_nan = re.compile(r"-?\b(?:NaN|Infinity)\b")
    try:
        service.migrate()
        with psycopg.connect(pg_url.replace("+psycopg", ""), autocommit=True) as conn:
            for sql, params in _old_rows():
                conn.execute(sql, tuple(no_nan.sub("null", p) if isinstance(p, str) else p for p in params))
        service.serve()
        _check_listings(service, nan=False)
    finally:
        service.stop()
