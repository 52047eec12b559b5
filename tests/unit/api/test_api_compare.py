"""GET /v1/compare on stored results: two evaluations, an evaluation against a campaign cell, unknown ids."""

from __future__ import annotations

import time

from sqlalchemy import insert

from foresight.core.evaluation.runner import write_records
from foresight.store.models import Artifact, Campaign, CampaignCell, Evaluation, Job
from tests.unit.evaluation.traces import record


def _rate(k: int, n: int, low: float, high: float) -> dict:
    return {"count": k, "n": n, "rate": k / n, "low": low, "high": high}


def _metrics(k: int, n: int, low: float, high: float) -> dict:
    """An evaluation row's metrics (EvaluationMetrics) with only a success rate in its overall group."""
    overall = {
        "key": "global",
        "episodes": n,
        "rates": {"success": _rate(k, n, low, high)},
        "means": {},
        "failed": [],
        "taxonomy": {},
    }
    return {
        "success_rate": k / n,
        "collision_rate": 0.0,
        "episodes": n,
        "status": "passed",
        "overall": overall,
    }


def _store(engine) -> None:  # noqa: ANN001
    unknown = {"n": 0, "mean": None, "low": None, "high": None}
    suite = {
        "episodes": 70,
        "success": _rate(56, 70, 0.6922, 0.8769),
        "collision": _rate(0, 70, 0.0, 0.05),
        "mean_min_clearance": unknown,
        "mean_min_distance": unknown,
        "mean_avg_speed": unknown,
        "taxonomy": {},
    }
    with engine.begin() as conn:
        for ident, metrics, horizon in (
            ("eval-a", _metrics(48, 80, 0.4904, 0.7000), 12),
            ("eval-b", _metrics(56, 70, 0.6922, 0.8769), 8),
        ):
            conn.execute(
                insert(Evaluation.__table__).values(
                    id=ident,
                    config={"planner": {"horizon": horizon}},
                    metrics=metrics,
                    per_scenario=[],
                    created_at=time.time(),
                )
            )
        conn.execute(
            insert(Campaign.__table__).values(
                id="camp", config={"grid": "grids/x.yaml"}, best=None, created_at=time.time()
            )
        )
        conn.execute(
            insert(CampaignCell.__table__).values(
                campaign_id="camp", rank=1, params={"variant": "v1"}, metrics={"global": suite, "hard": None}
            )
        )


def test_two_evaluations_diff_and_deltas_with_intervals(client, engine) -> None:  # noqa: ANN001
    _store(engine)
    body = client.get("/v1/compare", params={"a": "eval-a", "b": "eval-b"}).json()
    assert body["sources"] == {"a": "evaluation", "b": "evaluation"}
    assert body["config_diff"] == {"planner.horizon": {"a": 12, "b": 8}}
    success = body["metrics"]["success"]
    assert abs(success["delta"] - 0.2) < 1e-9 and success["significant"]
    assert abs(success["low"] - 0.0524) < 1e-3 and abs(success["high"] - 0.3339) < 1e-3  # Newcombe's example


def test_an_evaluation_against_a_campaign_cell(client, engine) -> None:  # noqa: ANN001
    _store(engine)
    body = client.get("/v1/compare", params={"a": "eval-a", "b": "camp:1"}).json()
    assert body["sources"]["b"] == "campaign cell (global suite)"
    assert body["config_diff"]["variant"] == {"a": None, "b": "v1"}
    assert abs(body["metrics"]["success"]["delta"] - 0.2) < 1e-9


def test_unknown_results_are_404_naming_them(client, engine) -> None:  # noqa: ANN001
    _store(engine)
    for b in ("nope", "camp:9", "camp:1:sideways", "camp:x"):
        r = client.get("/v1/compare", params={"a": "eval-a", "b": b})
        assert r.status_code == 404 and b.split(":")[0] in r.json()["detail"], (b, r.text)
    assert (
        client.get("/v1/compare", params={"a": "eval-a", "b": "camp:1:hard"}).status_code == 404
    )  # no hard suite


def _store_with_episodes(engine, settings, runs: dict[str, list]) -> None:  # noqa: ANN001
    """Evaluations whose jobs kept their episodes.jsonl under the store root (as a worker leaves them)."""
    with engine.begin() as conn:
        for ident, records in runs.items():
            path = settings.store_root / "jobs" / ident / "episodes.jsonl"
            path.parent.mkdir(parents=True, exist_ok=True)
            write_records(path, records)
            now = time.time()
            conn.execute(
                insert(Job.__table__).values(
                    id=ident, kind="evaluate", spec={}, status="succeeded", created_at=now
                )
            )
            conn.execute(
                insert(Artifact.__table__).values(
                    job_id=ident,
                    name="episodes.jsonl",
                    path=f"jobs/{ident}/episodes.jsonl",
                    size=1,
                    sha256="x",
                    created_at=now,
                )
            )
            metrics = _metrics(sum(r.success for r in records), len(records), 0.0, 1.0)
            conn.execute(
                insert(Evaluation.__table__).values(
                    id=ident, job_id=ident, config={}, per_scenario=[], metrics=metrics, created_at=now
                )
            )


def test_evaluations_of_the_same_episodes_are_paired(client, engine, settings) -> None:  # noqa: ANN001
    seeds = range(24)
    a = [
        record("s_low", s, "collision_pedestrian" if s < 8 else "success", ped_y=0.3 if s < 8 else 2.0)
        for s in seeds
    ]
    b = [record("s_low", s, "success") for s in seeds]
    _store_with_episodes(engine, settings, {"eval-a": a, "eval-b": b, "eval-c": b[:20]})
    body = client.get("/v1/compare", params={"a": "eval-a", "b": "eval-b"}).json()
    assert body["paired"] is True
    success = body["metrics"]["success"]
    assert success["method"] == "paired" and success["test"] == "mcnemar_exact"
    assert (
        success["discordant"] == [0, 8]
        and abs(success["p_value"] - 2 / 2**8) < 1e-12
        and success["significant"]
    )
    assert body["metrics"]["min_clearance"]["test"] == "wilcoxon_signed_rank"
    other = client.get(
        "/v1/compare", params={"a": "eval-a", "b": "eval-c"}
    ).json()  # other episodes: unpaired
    assert other["paired"] is False and other["metrics"]["success"]["method"] == "unpaired_mover"


def test_paired_evaluations_list_the_episodes_that_ended_otherwise(client, engine, settings) -> None:  # noqa: ANN001
    """The discordant pairs behind the McNemar test by name, with a side-by-side player where both kept the trace."""
    from foresight.core.render.episode_trace import trace_name

    a = [record("s_low", s, "timeout" if s in (3, 5) else "success") for s in range(6)]
    b = [record("s_low", s, "collision_pedestrian" if s == 1 else "success") for s in range(6)]
    _store_with_episodes(engine, settings, {"eval-a": a, "eval-b": b, "eval-c": b[:4]})
    for ident in ("eval-a", "eval-b"):  # both stored seed 3's trace; only eval-a stored seed 5's
        for seed in (3, 5) if ident == "eval-a" else (3,):
            path = settings.store_root / "jobs" / ident / trace_name("s_low", seed)
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(b"")
    body = client.get("/v1/compare", params={"a": "eval-a", "b": "eval-b"}).json()
    changed = body["changed_episodes"]
    assert [(e["scenario"], e["seed"], e["a"], e["b"]) for e in changed] == [
        ("s_low", 1, "success", "collision_pedestrian"),
        ("s_low", 3, "timeout", "success"),
        ("s_low", 5, "timeout", "success"),
    ]
    assert [e["player"] for e in changed] == [
        None,
        "/ui/compare/episode?a=eval-a&b=eval-b&scenario=s_low&seed=3",
        None,
    ]
    assert body["metrics"]["success"]["discordant"] == [1, 2]  # the same pairs, counted
    assert client.get("/v1/compare", params={"a": "eval-a", "b": "eval-c"}).json()["changed_episodes"] is None
    # a trace not stored, and one of no such evaluation: 404s that say which
    gone = client.get("/v1/evaluations/eval-b/episodes/s_low/5")
    assert (
        gone.status_code == 404
        and "evaluation eval-b stored no trace of s_low seed 5" in gone.json()["detail"]
    )
    unknown = client.get("/v1/evaluations/eval-zz/episodes/s_low/5")
    assert unknown.status_code == 404 and "no evaluation with id 'eval-zz'" in unknown.json()["detail"], (
        unknown.text
    )
    from foresight.cli.report import compare_text  # what `foresight compare A B` prints of this body

    assert (
        "episodes that ended otherwise (3; each with its side-by-side player where both kept the trace):\n"
        "  s_low 1: success -> collision_pedestrian\n"
        "  s_low 3: timeout -> success  http://h:1/ui/compare/episode?a=eval-a&b=eval-b&scenario=s_low&seed=3\n"
        "  s_low 5: timeout -> success"
    ) in compare_text(body, "http://h:1")


def test_compare_page_lists_them_and_links_the_side_by_side_player(client, engine, settings) -> None:  # noqa: ANN001
    from foresight.core.render.episode_trace import trace_name

    a = [record("s_low", s, "timeout" if s == 2 else "success") for s in range(4)]
    b = [record("s_low", s, "success") for s in range(4)]
    _store_with_episodes(engine, settings, {"eval-a": a, "eval-b": b})
    for ident in ("eval-a", "eval-b"):
        path = settings.store_root / "jobs" / ident / trace_name("s_low", 2)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(b"")
    text = client.get("/ui/compare", params={"a": "eval-a", "b": "eval-b"}).text
    assert "Episodes that ended otherwise (1)" in text
    link = "/ui/compare/episode?a=eval-a&amp;b=eval-b&amp;scenario=s_low&amp;seed=2"
    assert f'<a class="watch-pair" href="{link}">' in text
    pair = client.get(
        "/ui/compare/episode", params={"a": "eval-a", "b": "eval-b", "scenario": "s_low", "seed": 2}
    )
    assert pair.status_code == 200
    for ident, side in (("eval-a", "a"), ("eval-b", "b")):  # one pane per run, each reading its own trace
        assert f'id="pane-{side}" data-trace="/v1/evaluations/{ident}/episodes/s_low/2"' in pair.text
    missing = client.get(
        "/ui/compare/episode", params={"a": "eval-a", "b": "nope", "scenario": "s_low", "seed": 2}
    )
    assert missing.status_code == 404 and "nope" in missing.text


def test_two_campaign_cells_are_paired_with_their_changed_episodes_played_side_by_side(
    client, auth, engine, settings
) -> None:  # noqa: ANN001
    """A real (tiny) campaign run in its job's folder: each cell keeps its episodes and their traces, so two cells
    compare paired like two evaluations, per suite, and each changed episode plays side by side."""
    from foresight.core.evaluation.campaign import run_campaign
    from foresight.core.evaluation.config import CampaignConfig
    from foresight.core.runtime.context import StageContext
    from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
    from foresight.store import job_reads, queue, records

    spec = {
        "kind": "campaign",
        "seed_manifest": "seeds/classic_eval_hard_smoke.yaml",
        "scenarios": ["crossing_low"],
        "seeds_per_scenario": 2,
        "max_steps": 200,
        "variants": [{"name": "base"}, {"name": "crawl", "config": {"max_speed_ratio": 0.1}}],
    }
    job_id = client.post("/v1/jobs", json={"spec": spec}, headers=auth).json()["id"]
    claimed = queue.claim(engine, "w", ["campaign"], 30)
    work = settings.store_root / "jobs" / job_id
    work.mkdir(parents=True)
    config = CampaignConfig.model_validate({k: v for k, v in spec.items() if k != "kind"})
    result = run_campaign(
        config, StageContext(workdir=work, resolve_bundle=lambda _b: BUILTIN_CONFIG_ROOT)
    ).model_dump(mode="json")
    queue.finish(engine, job_id, "w", claimed["attempts"], result)
    with engine.begin() as conn:
        records.RECORDERS["campaign"](conn, job_reads.get_job(engine, job_id), result, f"jobs/{job_id}")
    rank = {c["variant"]: i for i, c in enumerate(result["ranked"], start=1)}
    base, crawl = (
        f"{job_id[:12]}:{rank['base']}",
        f"{job_id}:{rank['crawl']}",
    )  # a short campaign id works too

    body = client.get("/v1/compare", params={"a": base, "b": crawl}).json()
    assert (
        body["paired"] is True and body["metrics"]["success"]["n_pairs"] == 2
    )  # the global suite's 2 episodes
    changed = body["changed_episodes"]
    assert [(e["seed"], e["a"], e["b"]) for e in changed] == [
        (1000, "success", "timeout"),
        (1001, "success", "timeout"),
    ]
    hard = client.get("/v1/compare", params={"a": f"{base}:hard", "b": f"{crawl}:hard"}).json()
    ran = next(c for c in result["ranked"] if c["variant"] == "crawl")["changed_vs_baseline"][
        "hard"
    ]  # as the run saw
    got = [{k: e[k] for k in ("scenario", "seed", "a", "b")} for e in hard["changed_episodes"]]
    assert (
        got == ran
        and got
        and {(e["scenario"], e["seed"]) for e in got} <= {tuple(p) for p in result["suites"]["hard"]}
    )

    # each changed episode: a player page of both cells' runs, and each side's trace from its own cell
    player = changed[0]["player"]
    assert player.startswith("/ui/compare/episode?")
    page = client.get(player)
    assert page.status_code == 200, page.text
    traces = [t.split('"')[0] for t in page.text.split('data-trace="')[1:]]
    assert traces == [
        f"/v1/campaigns/{job_id}/cells/{rank[v]}/episodes/crossing_low/1000" for v in ("base", "crawl")
    ]
    runs = [client.get(t).json() for t in traces]
    assert runs[0] != runs[1] and all(r["frames"] for r in runs)
    assert len(runs[1]["frames"]) > len(
        runs[0]["frames"]
    )  # the crawling robot ran out of time, the other arrived

    # the campaign page links each cell to its comparison with the baseline cell, counting what ended otherwise
    campaign_page = client.get(f"/ui/campaigns/{job_id}").text
    assert f"/ui/compare?a={job_id}:{rank['base']}&amp;b={job_id}:{rank['crawl']}" in campaign_page
    assert "2 episodes ended otherwise" in campaign_page
    # a cell's episodes, suite by suite, failures first, each with its trace and its player
    listed = client.get(f"/v1/campaigns/{job_id[:12]}/cells/{rank['crawl']}/episodes").json()
    assert [(e["seed"], e["outcome"]) for e in listed] == [(1000, "timeout"), (1001, "timeout")]
    assert listed[0]["player"] == f"/ui/campaigns/{job_id}/cells/{rank['crawl']}/episodes/crossing_low/1000"
    assert client.get(listed[0]["trace"]).json() == runs[1]
    hard_listed = client.get(
        f"/v1/campaigns/{job_id}/cells/{rank['crawl']}/episodes", params={"suite": "hard"}
    ).json()
    assert {(e["scenario"], e["seed"]) for e in hard_listed} == {tuple(p) for p in result["suites"]["hard"]}
    assert all(e["player"] for e in hard_listed)
    cell_page = client.get(f"/ui/campaigns/{job_id}/cells/{rank['crawl']}").text
    assert cell_page.count('class="watch"') == len(listed) + len(hard_listed) and "variant crawl" in cell_page
    player_page = client.get(listed[0]["player"])
    assert player_page.status_code == 200 and f'data-trace="{listed[0]["trace"]}"' in player_page.text
    assert client.get(f"/ui/campaigns/{job_id}/cells/9").status_code == 404
    missing = client.get(f"/v1/campaigns/{job_id}/cells/{rank['base']}/episodes/crossing_low/7")
    assert missing.status_code == 404 and "campaign cell" in missing.json()["detail"]
    assert client.get(f"/v1/campaigns/{job_id}/cells/9/episodes/crossing_low/1000").status_code == 404
