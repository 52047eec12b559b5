"""Hostile inputs through the HTTP service (a real ``foresight serve`` it starts on a temporary SQLite file) and
through the core readers: what is refused, how fast, and whether anything breaks.

Prints one JSON object. ``service``: per class of hostile request (lone surrogates, NUL, integers beyond 64 bits,
names over 255 bytes, NaN/Infinity, deep nesting, reserved model ids, registration bounds, YAML bombs, hostile
archives, dashboard junk) the requests tried, their status codes, the 5xx among them and the connections dropped;
then ``crowd_size_bomb`` (a few-hundred-byte bundle whose map holds millions of pedestrians, and a planner with
100,000 speed ratios: status codes and wall time of each submission), ``million_key_yaml_bundle`` (the flat
10.9 MB YAML of 10^6 keys, refused by its size) and ``flat_yaml_under_the_byte_limit`` (350,000 keys, 3.7 MB,
which the node count refuses while parsing): status, wall time and the server's peak-memory growth. Then
``totals``: responses 500, connections dropped, records stored by refused requests, listings broken afterwards
(every list page and every job's and model's detail), whether the crowd bomb was refused at submission and in how
long, and the same for both flat YAMLs with their extra memory. ``core``: per case the outcome and CPU seconds of
the core readers, and the corrupted archives that failed without a clear error.
Run: ``.venv/bin/python bench/hostile_inputs.py`` (about a minute; ``--core-only`` skips the service).
"""

from __future__ import annotations

import io
import json
import sys
import time
import zipfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # tests.archives: the archive generator

from foresight.core.archive import read_archive  # noqa: E402
from foresight.core.errors import ConfigError  # noqa: E402
from foresight.core.limits import check_nesting  # noqa: E402
from foresight.core.maps.svg import parse_svg_text  # noqa: E402
from foresight.core.yamlio import load_yaml  # noqa: E402
from tests.archives import hostile, mangled  # noqa: E402


def alias_bomb(levels: int) -> str:
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, levels + 1)]
    return "\n".join(lines) + "\n"


def deep_json(depth: int) -> object:
    value: object = {}
    for _ in range(depth):
        value = {"k": value}
    return value


def measure(fn) -> dict:  # noqa: ANN001
    t0 = time.process_time()
    try:
        fn()
        outcome = "accepted"
    except Exception as exc:  # noqa: BLE001 - the outcome is what we report
        outcome = f"{type(exc).__name__}: {exc}"[:100]
    return {"outcome": outcome, "cpu_s": round(time.process_time() - t0, 4)}


def core_readers() -> dict:
    cases = {
        "yaml alias bomb, 7 levels (271 bytes in the probe)": lambda: load_yaml(alias_bomb(7), "bomb.yaml"),
        "yaml alias bomb, 10 levels": lambda: load_yaml(alias_bomb(10), "bomb.yaml"),
        "yaml nested 20,000 deep": lambda: load_yaml("a: " + "[" * 20_000 + "]" * 20_000, "deep.yaml"),
        "svg with 100,000 nested <g>": lambda: parse_svg_text(
            '<svg xmlns="http://www.w3.org/2000/svg" width="9" height="9">'
            + "<g>" * 100_000
            + "</g>" * 100_000
            + "</svg>",
            name="deep",
            source="deep.svg",
        ),
        "json spec nested 100,000 deep": lambda: check_nesting(deep_json(100_000), source="body"),
    }
    for name, (data, _, _) in hostile().items():
        cases[f"archive: {name} ({len(data)} bytes)"] = lambda d=data: read_archive(
            d, max_bytes=50 << 20, max_files=2000
        )
    out = {name: measure(fn) for name, fn in cases.items()}
    unclear = []
    for i, data in enumerate(mangled(seed=7, count=200)):
        try:
            read_archive(data, max_bytes=50 << 20, max_files=2000)
        except ConfigError:
            continue
        except Exception as exc:  # noqa: BLE001 - what is reported
            unclear.append(f"{i}: {type(exc).__name__}: {exc}"[:100])
    handled = sum(r["outcome"] != "accepted" and r["cpu_s"] < 2 for r in out.values())
    out["summary"] = {
        "hostile_inputs_tried": len(cases),
        "hostile_inputs_refused_within_2s": handled,
        "corrupted_archives_tried": 200,
        "corrupted_archives_without_a_clear_error": unclear,
    }
    return out


# ------------------------------------------------------------------------------------------------- the service
CAMPAIGN = {"kind": "campaign", "seed_manifest": "seeds/classic_eval_hard_smoke.yaml"}
LISTS = [
    "/v1/jobs",
    "/v1/models",
    "/v1/evaluations",
    "/v1/campaigns",
    "/v1/datasets",
    "/v1/bundles",
    "/v1/workers",
    "/v1/models/export",
    "/ui/jobs",
    "/ui/models",
    "/ui/results",
    "/ui/bundles",
]
COUNTED = ("/v1/jobs", "/v1/models", "/v1/bundles")  #: lists whose ``count`` a refused request must not raise


def _zip(files: dict[str, str | bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in files.items():
            z.writestr(name, data)
    return buf.getvalue()


def _raw(body: str) -> dict:
    """A JSON text sent as written (its ``\\ud800`` escapes and NaN tokens survive)."""
    return {"content": body.encode(), "headers": {"Content-Type": "application/json"}}


def _model(job_id: str, ident: str, fields: str) -> dict:
    """A model registration whose extra ``fields`` are JSON text as written."""
    return _raw('{"id": "' + ident + '", "job_id": "' + job_id + '", "artifact": "model.pt", ' + fields + "}")


def _requests(job_id: str) -> dict[str, list[tuple[str, str, dict]]]:
    """(method, path, httpx keyword arguments) per class; ``job_id`` is a finished job holding a checkpoint."""
    big, long = str(2**64), "n" * 300 + ".yaml"
    model = {"job_id": job_id, "artifact": "model.pt"}
    spec_variant = (
        '{"spec": {"kind": "campaign", "seed_manifest": "seeds/classic_eval_hard_smoke.yaml", '
        '"variants": [{"name": "v", "params": {"a": VALUE}}]}}'
    )
    return {
        "lone_surrogates": [
            ("POST", "/v1/jobs", _raw(spec_variant.replace("VALUE", '"\\ud800"'))),
            ("POST", "/v1/models", _model(job_id, "m", '"metrics": {"x": "\\ud800"}')),
            ("POST", "/v1/jobs", _raw('{"spec": {"kind": "sleep"}, "name": "a\\udfff"}')),
            ("POST", "/v1/jobs", _raw('{"spec": {"kind": "\\ud800"}}')),
            ("PATCH", f"/v1/jobs/{job_id}", _raw('{"note": "\\ud800"}')),
        ],
        "nul": [
            ("GET", path, {"params": {name: "a\x00b"}})
            for path, name in [
                ("/v1/jobs", "name"),
                ("/v1/jobs", "q"),
                ("/v1/evaluations", "planner"),
                ("/v1/evaluations", "matrix"),
                ("/v1/campaigns", "model"),
                ("/ui/jobs", "q"),
            ]
        ]
        + [
            ("POST", "/v1/models", {"json": {"id": "m-nul", **model, "provenance": "a\x00b"}}),
            ("POST", "/v1/jobs", {"json": {"spec": {"kind": "sleep"}, "note": "a\x00b"}}),
        ],
        "integers_beyond_64_bits": [
            ("GET", "/v1/compare", {"params": {"a": job_id, "b": f"{job_id}:99999999999999999999"}}),
            ("GET", f"/ui/campaigns/{job_id}/cells/{big}", {}),
            ("GET", "/ui/jobs", {"params": {"offset": big}}),
            ("GET", f"/v1/evaluations/{job_id}/episodes/s/{big}", {}),
            ("POST", "/v1/jobs", _raw('{"spec": {"kind": "sleep"}, "priority": ' + big + "}")),
            ("POST", "/v1/jobs", _raw('{"spec": {"kind": "collect", "base_seed": ' + big + "}}")),
            ("POST", "/v1/models", _model(job_id, "m-big", '"metrics": {"n": ' + big + "}")),
        ],
        "names_over_255_bytes": [
            ("POST", "/v1/jobs", {"json": {"spec": spec}})
            for spec in (
                {**CAMPAIGN, "seed_manifest": long, "variants": []},
                {**CAMPAIGN, "grid": long},
                {**CAMPAIGN, "matrix": long, "variants": []},
                {"kind": "collect", "hard_seeds": long},
                {"kind": "evaluate", "seed_manifest": f"x/{long}"},
            )
        ]
        + [
            (
                "POST",
                "/v1/bundles",
                {"params": {"name": "longname"}, "content": _zip({f"maps/{long}": "a: 1\n"})},
            )
        ],
        "nan_infinity": [
            ("POST", "/v1/models", _model(job_id, "m-nan", '"metrics": {"x": NaN}')),
            ("POST", "/v1/models", _model(job_id, "m-inf", '"training": {"x": Infinity}')),
            ("POST", "/v1/jobs", _raw(spec_variant.replace("VALUE", "NaN"))),
            ("POST", "/v1/jobs", _raw('{"spec": {"kind": "sleep"}, "timeout_s": Infinity}')),
        ],
        "deep_nesting": [
            ("POST", "/v1/jobs", _raw('{"spec": {"kind": "sleep", "x": ' + "[" * depth + "]" * depth + "}}"))
            for depth in (100, 5_000, 100_000)
        ],
        "reserved_model_ids": [
            ("POST", "/v1/models", {"json": {"id": i, **model}}) for i in ("default", "cv", "none", "Default")
        ],
        "registration_bounds": [
            (
                "POST",
                "/v1/models",
                {"json": {"id": "m-huge", **model, "metrics": {f"k{i}": "x" * 1000 for i in range(10_000)}}},
            ),
            (
                "POST",
                "/v1/models",
                {"json": {"id": "m-tb", **model, "time_base": {"dt": -1, "history": 10**9, "horizon": 1}}},
            ),
        ],
        "submission_checks": [
            (
                "POST",
                "/v1/jobs",
                {"json": {"spec": {**CAMPAIGN, "variants": [{"name": "v", "params": {"zzz": 1}}]}}},
            ),
            (
                "POST",
                "/v1/jobs",
                {"json": {"spec": {"kind": "collect", "evaluation_seeds": "seeds/missing.yaml"}}},
            ),
        ],
        "yaml_bombs": [
            (
                "POST",
                "/v1/bundles",
                {"params": {"name": "alias"}, "content": _zip({"scenarios/a.yaml": alias_bomb(7)})},
            ),
            (
                "POST",
                "/v1/bundles",
                {
                    "params": {"name": "deep"},
                    "content": _zip({"scenarios/d.yaml": "a: " + "[" * 20_000 + "]" * 20_000}),
                },
            ),
            (
                "POST",
                "/v1/bundles",
                {
                    "params": {"name": "string"},
                    "content": _zip({"scenarios/s.yaml": 'a: "' + "x" * 49_000_000 + '"'}),
                },
            ),
            (
                "POST",
                "/v1/bundles",
                {
                    "params": {"name": "clash"},
                    "content": _zip({"maps/c.yaml": "a: 1\n", "maps/c.yaml/d.yaml": "a: 1\n"}),
                },
            ),
        ],
        "hostile_archives": [
            ("POST", "/v1/bundles", {"params": {"name": f"h{i}"}, "content": data})
            for i, (data, _, _) in enumerate(hostile().values())
        ],
        "dashboard": [
            ("GET", f"/ui/evaluations/{job_id}/episodes/crossing_low/1", {}),
            ("GET", "/ui/jobs", {"params": {"zzz": "1"}}),
            ("GET", "/ui/models", {"params": {"junk": "x"}}),
        ],
    }


def _peak_rss(pid: int, *, reset: bool = False) -> int:
    """[bytes] the process's peak resident memory (Linux); ``reset`` starts a new peak at its current size."""
    if reset:
        Path(f"/proc/{pid}/clear_refs").write_text("5")
    line = next(li for li in Path(f"/proc/{pid}/status").read_text().splitlines() if li.startswith("VmHWM:"))
    return int(line.split()[1]) * 1024


def _checkpoint_job(engine, store: Path) -> str:  # noqa: ANN001
    """A succeeded job whose folder holds the shipped checkpoint as ``model.pt`` (what registration needs)."""
    from foresight.store import folders, queue
    from foresight.store.settings import REPO_ROOT

    job, _ = queue.submit(engine, kind="sleep", spec={"kind": "sleep"})
    claimed = queue.claim_id(engine, job["id"], "bench", 30)
    rel = f"{folders.job_dir(store, job['id'])}/model.pt"
    folders.write_atomic(
        folders.resolve_under(store, rel), (REPO_ROOT / "model" / "predictor-sim-default.pt").read_bytes()
    )
    queue.finish(
        engine,
        job["id"],
        "bench",
        claimed["attempts"],
        {},
        folders.scan(store, folders.job_dir(store, job["id"])),
    )
    return job["id"]


def _flat_yaml(http, pid: int, keys: int) -> dict:  # noqa: ANN001 - an httpx.Client
    """A bundle holding a flat YAML of ``keys`` keys (10^6: 10.9 MB, the probe's file; 350,000: 3.7 MB, under the
    byte limit, so the node count refuses it while parsing): its status, the start of its message, wall time and
    the server's peak-memory growth while refusing it."""
    text = "".join(f"k{i}: 1\n" for i in range(keys))
    flat = _zip({"scenarios/flat.yaml": text})
    peak = _peak_rss(pid, reset=True)
    t0 = time.monotonic()
    r = http.post("/v1/bundles", params={"name": "flat"}, content=flat)
    return {
        "yaml_bytes": len(text),
        "zipped_bytes": len(flat),
        "status": r.status_code,
        "message": r.text[:200],
        "seconds": round(time.monotonic() - t0, 2),
        "server_peak_rss_growth_mb": round((_peak_rss(pid) - peak) / 2**20, 1),
    }


def _crowd_bomb(http) -> dict:  # noqa: ANN001 - an httpx.Client
    """A few-hundred-byte bundle whose map has a 10^6 m pedestrian route at ``ped_density`` 2 (millions of
    pedestrians), then an evaluation and a simulation of it and a planner with 100,000 speed ratios, each submitted
    with a 120 s timeout: their status codes and wall times (each the faster of two tries, as the test does)."""
    import tarfile

    from tests.integration.test_service_bounds import LONG_ROUTE_MAP, MATRIX, PLAZA_MAP

    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz") as tar:
        for name, data in {
            "maps/long.yaml": LONG_ROUTE_MAP,
            "maps/plaza.yaml": PLAZA_MAP,
            "scenarios/m.yaml": MATRIX,
        }.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    bundle = http.post(
        "/v1/bundles",
        params={"name": "crowds"},
        content=buf.getvalue(),
        headers={"Content-Type": "application/gzip"},
    )
    on_bundle = {"bundle": "crowds", "matrix": "scenarios/m.yaml", "scenarios": ["bomb"]}
    specs = [
        {"kind": "evaluate", **on_bundle, "seeds_per_scenario": 1, "planner": {"name": "goal"}},
        {"kind": "simulate", **on_bundle},
        {
            "kind": "evaluate",
            "scenarios": ["crossing_low"],
            "seeds_per_scenario": 1,
            "planner": {
                "name": "predictive",
                "model": "cv",
                "config": {"sampling": {"speed_ratios": [0.5] * 100_000}},
            },
        },
    ]
    codes, seconds = [], []
    for spec in specs:
        took = []
        for _ in range(2):
            t0 = time.monotonic()
            r = http.post("/v1/jobs", json={"spec": spec, "timeout_s": 120})
            took.append(time.monotonic() - t0)
        codes.append(r.status_code)
        seconds.append(round(min(took), 3))
    return {
        "bundle_bytes": len(buf.getvalue()),
        "bundle_status": bundle.status_code,
        "status": codes,
        "seconds": seconds,
    }


def _broken_listings(http) -> list[str]:  # noqa: ANN001 - an httpx.Client
    """The list pages, and every job's and model's detail, that do not answer 200."""
    broken = [p for p in LISTS if http.get(p).status_code != 200]
    jobs = http.get("/v1/jobs", params={"limit": 500}).json().get("data", [])
    models = http.get("/v1/models").json().get("data", [])
    details = [f"/v1/jobs/{j['id']}" for j in jobs] + [f"/ui/jobs/{j['id']}" for j in jobs]
    details += [f"/v1/models/{m['id']}" for m in models]
    return broken + [p for p in details if http.get(p).status_code != 200]


def run_service() -> dict:
    """Every class of hostile request against a real server, then the listings and the stored counts."""
    import tempfile

    import httpx

    from foresight.store.session import make_engine
    from tests.integration.service import Service

    tmp = Path(tempfile.mkdtemp(prefix="foresight-hostile-"))
    svc = Service(tmp)
    svc.migrate()
    svc.serve()
    engine = make_engine(f"sqlite:///{tmp / 'data' / 'foresight.db'}")
    out: dict = {}
    try:
        job_id = _checkpoint_job(engine, tmp / "data" / "store")
        with svc.client() as http:
            before = {p: http.get(p).json()["count"] for p in COUNTED}
            out["flat_yaml_under_the_byte_limit"] = _flat_yaml(http, svc.procs[0].pid, 350_000)
            out["million_key_yaml_bundle"] = _flat_yaml(http, svc.procs[0].pid, 1_000_000)
            out["crowd_size_bomb"] = _crowd_bomb(http)
            accepted = int(out["crowd_size_bomb"]["bundle_status"] == 201)  # the crowd bomb's bundle
            for name, requests in _requests(job_id).items():
                codes: dict[str, int] = {}
                dropped = 0
                t0 = time.monotonic()
                for method, path, kwargs in requests:
                    try:
                        r = http.request(method, path, **kwargs)
                    except httpx.HTTPError:
                        dropped += 1
                        continue
                    codes[str(r.status_code)] = codes.get(str(r.status_code), 0) + 1
                    dropped += r.headers.get("connection") == "close"
                    accepted += r.status_code in (200, 201) and method == "POST"
                out[name] = {
                    "tried": len(requests),
                    "status": codes,
                    "5xx": sum(v for k, v in codes.items() if k >= "500"),
                    "connections_dropped": dropped,
                    "seconds": round(time.monotonic() - t0, 2),
                }
            after = {p: http.get(p).json()["count"] for p in COUNTED}
            broken = _broken_listings(http)
            flat, bomb = out["million_key_yaml_bundle"], out["crowd_size_bomb"]
            nodes = out["flat_yaml_under_the_byte_limit"]
            out["totals"] = {
                "requests": sum(c["tried"] for c in out.values() if "tried" in c)
                + 2
                + 2 * len(bomb["status"]),
                "responses_500": sum(c.get("5xx", 0) for c in out.values())
                + sum(
                    c >= 500
                    for c in [flat["status"], nodes["status"], bomb["bundle_status"], *bomb["status"]]
                ),
                "connections_dropped": sum(c.get("connections_dropped", 0) for c in out.values()),
                "stored_by_refused_requests": sum(after.values()) - sum(before.values()) - accepted,
                "listings_broken": len(broken),
                "listings_broken_paths": broken,
                "crowd_bomb_refused_at_submission": all(c == 422 for c in bomb["status"]),
                "crowd_bomb_seconds": max(bomb["seconds"]),
                "million_key_yaml_refused": 400 <= flat["status"] < 500,
                "million_key_yaml_seconds": flat["seconds"],
                "million_key_yaml_server_memory_mb": flat["server_peak_rss_growth_mb"],
                "flat_yaml_350k_keys_refused": 400 <= nodes["status"] < 500,
                "flat_yaml_350k_keys_seconds": nodes["seconds"],
                "flat_yaml_350k_keys_server_memory_mb": nodes["server_peak_rss_growth_mb"],
            }
    finally:
        engine.dispose()
        svc.stop()
    return out


def main() -> None:
    out = {} if "--core-only" in sys.argv else {"service": run_service()}
    out["core"] = core_readers()
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
