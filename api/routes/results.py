"""Results of finished stages: datasets, evaluations (with their taxonomy), campaigns, A/B comparison."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Query, Response

from foresight.api.deps import EngineDep, SettingsDep
from foresight.api.errors import responses
from foresight.api.schemas import Ident, Rank
from foresight.core.runtime.refs import Seed
from foresight.result_schemas import CampaignPublic, EpisodePublic, EvaluationPublic
from foresight.schemas import DatasetPublic
from foresight.store import job_reads, queue, results

router = APIRouter(tags=["results"])


def full_id(engine: Any, ident: str) -> str:
    """An evaluation or campaign id (a job's) given by a short id, as the CLI prints; ``ID:RANK[:SUITE]`` cells too."""
    head, sep, rest = ident.partition(":")
    return job_reads.resolve_id(engine, head) + sep + rest


@router.get("/datasets")
def read_datasets(engine: EngineDep) -> list[DatasetPublic]:
    """Datasets, oldest first."""
    return [DatasetPublic.model_validate(d) for d in results.datasets(engine)]


@router.get("/datasets/{dataset_id}", responses=responses(404))
def read_dataset(dataset_id: Ident, engine: EngineDep) -> DatasetPublic:
    """A dataset's summary."""
    return DatasetPublic.model_validate(results.dataset(engine, dataset_id))


@router.get("/data-roots")
def read_data_roots(settings: SettingsDep) -> list[dict[str, Any]]:
    """Named data roots an ``import_dataset`` job may read (``FORESIGHT_DATA_ROOTS``), with the ETH/UCY folds
    found in each; names only, the server's folders stay private."""
    from foresight.core.predict.ethucy import FOLDS

    return [
        {"name": name, "folds": [f for f in FOLDS if (path / f).is_dir()]}
        for name, path in sorted(settings.named_data_roots.items())
    ]


@router.get("/evaluations/{evaluation_id}", responses=responses(404))
def read_evaluation(evaluation_id: Ident, engine: EngineDep) -> EvaluationPublic:
    """Metrics, the per-scenario table and the failure taxonomy of an evaluation (id or a short id of its job)."""
    evaluation_id = full_id(engine, evaluation_id)
    row, taxonomy = results.evaluation(engine, evaluation_id)
    out = EvaluationPublic.model_validate(row)
    out.taxonomy = taxonomy
    return out


@router.get("/campaigns/{campaign_id}", responses=responses(404))
def read_campaign(campaign_id: Ident, engine: EngineDep) -> CampaignPublic:
    """A campaign's ranked cells, best cell and gate results."""
    row, cells, gates = results.campaign(engine, full_id(engine, campaign_id))
    return CampaignPublic(
        id=row.id, job_id=row.job_id, config=row.config, best=row.best, cells=cells, gates=gates
    )


@router.get("/evaluations/{evaluation_id}/episodes", responses=responses(404))
def read_evaluation_episodes(
    evaluation_id: Ident, engine: EngineDep, settings: SettingsDep
) -> list[EpisodePublic]:
    """Every episode of an evaluation (failures first): outcome, failure label, and the URL of its trace for the
    episode player (``trace`` is None where the evaluation stored none, e.g. before traces were kept)."""
    return episode_list(engine, settings, full_id(engine, evaluation_id))


TableFormat = Annotated[Literal["csv", "parquet", "jsonl"], Query(description="csv, parquet or jsonl")]


@router.get("/evaluations/{evaluation_id}/episodes/export", responses=responses(404), response_class=Response)
def export_evaluation_episodes(
    evaluation_id: Ident, engine: EngineDep, settings: SettingsDep, format: TableFormat = "csv"
) -> Response:
    """Every episode of an evaluation as a flat table (one row per episode, a column per metric, dotted names
    such as ``safety.min_clearance``), in run order: CSV, Parquet or JSON lines."""
    return _export(engine, settings, full_id(engine, evaluation_id), format)


@router.get(
    "/campaigns/{campaign_id}/cells/{rank}/episodes/export", responses=responses(404), response_class=Response
)
def export_cell_episodes(
    campaign_id: Ident,
    rank: int,
    engine: EngineDep,
    settings: SettingsDep,
    suite: Annotated[Literal["global", "hard"], Query()] = "global",
    format: TableFormat = "csv",
) -> Response:
    """A campaign cell's episodes of one suite as :func:`export_evaluation_episodes` writes them."""
    return _export(engine, settings, f"{full_id(engine, campaign_id)}:{rank}:{suite}", format)


def _export(engine: Any, settings: Any, ident: str, fmt: str) -> Response:
    from foresight.core.evaluation.episode_table import MEDIA_TYPES, encode, export_jsonl

    folder = results.run_folder(engine, settings.store_root, ident)
    name = f"episodes-{ident.replace(':', '-')}.{fmt}"
    headers = {"Content-Disposition": f'attachment; filename="{name}"'}
    whole = None if folder is None or folder.episodes is not None else folder.path / "episodes.jsonl"
    if whole is not None and whole.is_file():  # an evaluation: its file as it is, the fast way
        return Response(export_jsonl(whole, fmt), media_type=MEDIA_TYPES[fmt], headers=headers)
    records = _records(folder)
    if records is None:
        results.comparison_operand(engine, ident)  # 404 for an unknown id
        records = []
    return Response(encode(records, fmt), media_type=MEDIA_TYPES[fmt], headers=headers)


@router.get("/evaluations/{evaluation_id}/episodes/{scenario}/{seed}", responses=responses(404))
def read_episode_trace(
    evaluation_id: Ident, scenario: Ident, seed: Seed, engine: EngineDep, settings: SettingsDep
) -> dict[str, Any]:
    """One episode's compact trace (core.render.episode_trace): robot, pedestrians with ids, goal and
    tolerance, walls, collision, logged forecasts; what the dashboard's episode player draws."""
    return _trace(engine, settings, full_id(engine, evaluation_id), scenario, seed)


@router.get("/campaigns/{campaign_id}/cells/{rank}/episodes", responses=responses(404))
def read_cell_episodes(
    campaign_id: Ident,
    rank: Rank,
    engine: EngineDep,
    settings: SettingsDep,
    suite: Annotated[Literal["global", "hard"], Query()] = "global",
) -> list[EpisodePublic]:
    """Every episode of a campaign cell's suite (rank 1 = best; failures first), with the URLs of its trace and
    player (None where the cell kept none: cells written before cells kept their run folders)."""
    return episode_list(engine, settings, f"{full_id(engine, campaign_id)}:{rank}:{suite}")


@router.get("/campaigns/{campaign_id}/cells/{rank}/episodes/{scenario}/{seed}", responses=responses(404))
def read_cell_episode_trace(
    campaign_id: Ident, rank: Rank, scenario: Ident, seed: Seed, engine: EngineDep, settings: SettingsDep
) -> dict[str, Any]:
    """One episode's compact trace as a campaign cell (rank 1 = best) ran it: the same shape as an evaluation's."""
    return _trace(engine, settings, f"{full_id(engine, campaign_id)}:{rank}", scenario, seed)


@router.get("/jobs/{job_id}/witnesses/{scenario}/{seed}", responses=responses(404))
def read_witness_trace(
    job_id: Ident, scenario: Ident, seed: Seed, engine: EngineDep, settings: SettingsDep
) -> dict[str, Any]:
    """The compact trace of a witness job's witness for one episode (the same shape as an evaluation's episode
    trace): what the dashboard plays beside the planner's run of that episode."""
    from foresight.core.render.episode_trace import read_compact, trace_name
    from foresight.store import folders

    job = job_reads.get_job(engine, full_id(engine, job_id))
    root = settings.store_root
    path = folders.resolve_under(root, folders.job_dir(root, job["id"])) / trace_name(scenario, seed)
    if job["kind"] != "witness" or not path.is_file():
        raise queue.JobNotFound(f"job {job['id']} found no witness for {scenario} seed {seed}")
    return read_compact(path)


def _trace(engine: Any, settings: Any, ident: str, scenario: str, seed: int) -> dict[str, Any]:
    from foresight.core.render.episode_trace import read_compact, trace_name

    folder = results.run_folder(engine, settings.store_root, ident)
    path = None if folder is None else folder.trace(trace_name(scenario, seed))
    if path is None:
        what = "evaluation" if ":" not in ident else "campaign cell"
        raise queue.JobNotFound(f"{what} {ident} stored no trace of {scenario} seed {seed}")
    return read_compact(path)


def trace_url(ident: str, scenario: str, seed: int) -> str:
    """The API URL of one episode's trace of an evaluation id or campaign cell ``CAMPAIGN_ID:RANK[:SUITE]``."""
    return f"/v1{_episode_path(ident, scenario, seed)}"


def player_url(ident: str, scenario: str, seed: int) -> str:
    """The dashboard URL of one episode's player, of an evaluation id or campaign cell."""
    return f"/ui{_episode_path(ident, scenario, seed)}"


def _episode_path(ident: str, scenario: str, seed: int) -> str:
    campaign_id, cell, rest = ident.partition(":")
    if not cell:
        return f"/evaluations/{ident}/episodes/{scenario}/{seed}"
    return f"/campaigns/{campaign_id}/cells/{rest.partition(':')[0]}/episodes/{scenario}/{seed}"


def episode_list(engine: Any, settings: Any, ident: str) -> list[EpisodePublic]:
    """The episodes of an evaluation or of a campaign cell's suite, failures first (by label), then in run order."""
    from foresight.core.render.episode_trace import trace_name

    folder = results.run_folder(engine, settings.store_root, ident)
    records = _records(folder)
    if records is None:
        results.comparison_operand(engine, ident)  # 404 for an unknown id
        records = []
    out = []
    for r in records:
        has = folder is not None and folder.trace(trace_name(r.scenario, r.seed)) is not None
        out.append(
            EpisodePublic(
                scenario=r.scenario,
                seed=r.seed,
                outcome=r.outcome,
                label=r.taxonomy.label,
                steps=r.steps,
                trace=trace_url(ident, r.scenario, r.seed) if has else None,
                player=player_url(ident, r.scenario, r.seed) if has else None,
            )
        )
    return sorted(out, key=lambda e: e.outcome == "success")


def _records(folder: results.RunFolder | None) -> list[Any] | None:
    """The episode records of a run folder (a campaign cell's: of its suite), None where none are kept."""
    return None if folder is None else folder.records()


@router.get("/compare", responses=responses(404))
def compare_evaluations(
    engine: EngineDep, settings: SettingsDep, a: Annotated[Ident, Query()], b: Annotated[Ident, Query()]
) -> dict[str, Any]:
    """Two evaluations or campaign cells (``CAMPAIGN_ID:RANK[:hard]``) side by side: what differs first (``differs``:
    planner, model, matrix, episodes, horizon, from each side's canonical ``setup``), the resolved-config diff
    key by key and the headline metric deltas B - A with 95 % intervals. Two results of the same (scenario, seed)
    episodes (evaluations, or cells of campaigns that kept their cells' run folders) are paired (McNemar / Wilcoxon
    p-values with matching intervals); the other metrics, and results of other episodes, use MOVER from each side's
    intervals (``method`` per metric). ``changed_episodes`` (paired results only, else None): the episodes whose
    outcome differs, each with the URL of a player showing both runs of it side by side."""
    return compare_results(engine, settings, a, b)


def compare_results(engine: Any, settings: Any, a: str, b: str) -> dict[str, Any]:
    """The body of ``GET /v1/compare`` (the dashboard's compare page renders the same)."""
    from foresight.core.evaluation.delta import (
        changed_episodes,
        deltas,
        diff_configs,
        paired_deltas,
        what_differs,
    )

    a, b = full_id(engine, a), full_id(engine, b)

    (kind_a, config_a, sum_a), (kind_b, config_b, sum_b) = (
        results.comparison_operand(engine, a),
        results.comparison_operand(engine, b),
    )
    folders = {ident: results.run_folder(engine, settings.store_root, ident) for ident in (a, b)}
    ra, rb = _records(folders[a]), _records(folders[b])
    paired = paired_deltas(ra, rb) if ra and rb else None
    metrics = {**deltas(sum_a, sum_b), **(paired or {})}
    setup_a, setup_b = results.comparison_setup(engine, a), results.comparison_setup(engine, b)
    changed = changed_episodes(ra, rb) if paired is not None else None
    return {
        "a": a,
        "b": b,
        "sources": {"a": kind_a, "b": kind_b},
        "setup": {"a": setup_a, "b": setup_b},
        "differs": what_differs(setup_a, setup_b) if setup_a and setup_b else None,
        "config_diff": diff_configs(config_a, config_b),
        "paired": paired is not None,
        "metrics": {k: v.model_dump() for k, v in metrics.items()},
        "changed_episodes": None if changed is None else _with_players(folders, a, b, changed),
    }


def _with_players(folders: dict[str, Any], a: str, b: str, changed: list[Any]) -> list[dict[str, Any]]:
    """Changed episodes with the URL of their side-by-side player (None unless both results stored the trace)."""
    from urllib.parse import urlencode

    from foresight.core.render.episode_trace import trace_name

    def both(e: Any) -> bool:
        return all(
            folders[i] is not None and folders[i].trace(trace_name(e.scenario, e.seed)) for i in (a, b)
        )

    return [
        {
            **e.model_dump(),
            "player": "/ui/compare/episode?"
            + urlencode({"a": a, "b": b, "scenario": e.scenario, "seed": e.seed})
            if both(e)
            else None,
        }
        for e in changed
    ]
