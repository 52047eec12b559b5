"""Real-data predictors in closed loop: on replay scenarios (recorded ETH/UCY people), the predictive planner driven by
an ETH/UCY-trained model that never saw the replay's scene, by the simulator-trained default and by constant velocity,
on the same episodes.

For each replay scenario of the matrix (default: the stress suite's ``replay_*``, every seed it has), the ETH/UCY
model is the fold model whose held-out (test) scene is the replay's scene (``core.predict.held_out``: leave one scene
out, read from each checkpoint's recorded scenes); a model that trained or chose its epoch on that scene is refused,
naming the scene and the model (``--model-for`` pairs a scene with a model of your choosing, under the same check).
Fold models: ``foresight predict-eval --local --train --config configs/training/ethucy.yaml --ethucy ROOT --fold F
--out DIR/F`` per fold, then ``--fold-models DIR``. The planner is built as ``foresight evaluate --planner predictive
--model M`` builds it (``plannerspec.load_model``, ``make_planner``); an ETH/UCY model forecasts at its 0.4 s, and the
planner resamples to its step. ``--json`` prints ONE object: per predictor success and collision counts with Wilson 95 %
intervals, timeouts and per-scene successes; paired counts (reference-only : other-only) with McNemar's exact p for
success and for collision; the ETH/UCY model of each scene (id, sha256, held-out and training scenes); and every
episode with its predictor, model id and held-out scene.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from functools import cache
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from foresight.core.errors import CoreError  # noqa: E402
from foresight.core.evaluation.stats import mcnemar_p, wilson_interval  # noqa: E402
from foresight.core.predict.held_out import SceneLineage, model_for_scene, read_lineage, require_held_out  # noqa: E402
from foresight.core.scenarios.loader import load_matrix  # noqa: E402

MATRIX = REPO / "configs" / "scenarios" / "stress.yaml"
PREDICTORS = ("ethucy", "default", "cv")  #: the first is the reference of the paired counts
COLLISIONS = ("collision_pedestrian", "collision_static")
SKIP_PARTS = {
    "members",
    "checkpoints",
    "proxy_checkpoints",
}  #: ensemble members and epoch checkpoints, not models


@cache
def _matrix(path: str):  # noqa: ANN202
    return load_matrix(Path(path))


def fold_checkpoints(paths: list[str]) -> list[Path]:
    """Checkpoint files: each path as given, or every ``model.pt`` under a folder (not a member's or an epoch's)."""
    found: list[Path] = []
    for value in paths:
        p = Path(value).expanduser()
        if p.is_file():
            found.append(p)
        elif p.is_dir():
            hits = sorted(
                c for c in p.rglob("model.pt") if not SKIP_PARTS.intersection(c.relative_to(p).parts[:-1])
            )
            if not hits:
                raise CoreError(f"--fold-models {value}: no model.pt under this folder")
            found.extend(hits)
        else:
            raise CoreError(f"--fold-models {value}: no such file or folder")
    return found


def choose_models(
    scenes: list[str], candidates: list[SceneLineage], pinned: dict[str, SceneLineage]
) -> dict[str, SceneLineage]:
    """The ETH/UCY model of each replay scene: the pinned one (``--model-for``), else the fold model holding it out;
    either way refused when it trained on the scene."""
    if stray := sorted(set(pinned) - set(scenes)):
        raise CoreError(
            f"--model-for {stray[0]}: no chosen replay scenario is of that scene ({', '.join(scenes)})"
        )
    chosen = {}
    for scene in scenes:
        if scene in pinned:
            require_held_out(pinned[scene], scene)
            chosen[scene] = pinned[scene]
        else:
            chosen[scene] = model_for_scene(scene, candidates)
    return chosen


def _episode(job: tuple) -> dict:
    """One episode (in a worker process): the planner as ``foresight evaluate --planner predictive`` builds it."""
    matrix_path, name, seed, which, model_path, sha, model_id, max_steps = job
    from foresight.core.evaluation.plannerspec import load_model
    from foresight.core.planners.registry import make_planner
    from foresight.core.sim.episode import run_episode

    sc = _matrix(matrix_path).get(name)
    model = "cv" if model_path is None else load_model(model_path, sha, model_id)
    res = run_episode(sc, seed, make_planner("predictive", None, model=model), max_steps=max_steps)
    return {"scenario": name, "seed": seed, "predictor": which, "model_id": model_id, "outcome": res.outcome}


def summarize(rows: list[dict], scene_of: dict[str, str]) -> dict:
    """Per predictor counts with Wilson intervals, per-scene successes, and the paired counts against the first."""
    which = [w for w in PREDICTORS if any(r["predictor"] == w for r in rows)]
    outcome = {(r["scenario"], r["seed"], r["predictor"]): r["outcome"] for r in rows}
    episodes = sorted({(r["scenario"], r["seed"]) for r in rows})
    n = len(episodes)
    out: dict = {"predictors": {}, "paired": {}}
    for w in which:
        got = Counter(outcome[e + (w,)] for e in episodes)
        coll = sum(got[c] for c in COLLISIONS)
        per_scene: dict[str, list[int]] = {}
        for e in episodes:
            s = per_scene.setdefault(scene_of[e[0]], [0, 0])
            s[0] += outcome[e + (w,)] == "success"
            s[1] += 1
        out["predictors"][w] = {
            "success": got["success"],
            "success_rate": got["success"] / n,
            "success_interval": wilson_interval(got["success"], n),
            "collisions": coll,
            "collision_rate": coll / n,
            "collision_interval": wilson_interval(coll, n),
            "timeouts": got["timeout"],
            "success_per_scene": {k: f"{a}/{b}" for k, (a, b) in sorted(per_scene.items())},
        }
    ref = which[0]
    for w in which[1:]:
        pair = {}
        for what, hit in (("success", lambda o: o == "success"), ("collision", lambda o: o in COLLISIONS)):
            a = sum(hit(outcome[e + (ref,)]) and not hit(outcome[e + (w,)]) for e in episodes)
            b = sum(hit(outcome[e + (w,)]) and not hit(outcome[e + (ref,)]) for e in episodes)
            pair[what] = {f"{ref}_only": a, f"{w}_only": b, "mcnemar_p": mcnemar_p(a, b)}
        out["paired"][f"{ref}_vs_{w}"] = pair
    return {"episodes": n, **out}


def _args() -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--fold-models",
        nargs="+",
        required=True,
        help="ETH/UCY fold checkpoints, or folders searched for model.pt (predict-eval --train --out folders)",
    )
    ap.add_argument("--matrix", default=str(MATRIX), help="scenario matrix holding replay scenarios")
    ap.add_argument(
        "--scenarios", help="comma-separated replay scenario names (default: every replay scenario)"
    )
    ap.add_argument(
        "--model-for",
        action="append",
        default=[],
        metavar="SCENE=PATH",
        help="the ETH/UCY model of one replay scene (checked like the others: refused if it trained on the scene)",
    )
    ap.add_argument(
        "--default-model", default="default", help="the simulator-trained model (registry id or path)"
    )
    ap.add_argument("--max-steps", type=int, help="episode length override (smoke runs)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", action="store_true")
    return ap.parse_args()


def _plan(args: argparse.Namespace) -> tuple[list, dict[str, str], dict[str, SceneLineage], dict]:
    """The episode jobs, the scene of each scenario, the ETH/UCY model of each scene and the default model."""
    from foresight.core.evaluation.plannerspec import sha256_file
    from foresight.local import ModelArgs

    matrix = _matrix(args.matrix)
    replays = [s for s in matrix.scenarios if s.scenario.replay is not None]
    if args.scenarios:
        names = [n.strip() for n in args.scenarios.split(",")]
        bad = [n for n in names if n not in {s.name for s in replays}]
        if bad:
            raise CoreError(f"--scenarios: {bad[0]!r} is not a replay scenario of {args.matrix}")
        replays = [s for s in replays if s.name in names]
    if not replays:
        raise CoreError(f"{args.matrix}: no replay scenarios (matrix entries with a replay block)")
    scene_of = {s.name: s.scenario.replay.scene for s in replays}
    candidates = [read_lineage(p, str(p)) for p in fold_checkpoints(args.fold_models)]
    pinned = {}
    for item in args.model_for:
        scene, sep, path = item.partition("=")
        if not sep or not Path(path).is_file():
            raise CoreError(f"--model-for {item!r}: expected SCENE=PATH of a checkpoint file")
        pinned[scene] = read_lineage(Path(path), path)
    chosen = choose_models(sorted(set(scene_of.values())), candidates, pinned)
    models = ModelArgs()
    default_id = models.ident(args.default_model)
    default_id = models.default() if default_id == "default" else default_id
    default_path = models.resolve(default_id)
    default = {"model_id": default_id, "checkpoint": str(default_path), "sha256": sha256_file(default_path)}
    jobs = []
    for s in replays:
        lin = chosen[scene_of[s.name]]
        for seed in s.scenario.seeds:
            for which, path, sha, ident in (
                ("ethucy", str(lin.path), lin.sha256, lin.model_id),
                ("default", default["checkpoint"], default["sha256"], default_id),
                ("cv", None, None, "cv"),
            ):
                jobs.append((args.matrix, s.name, int(seed), which, path, sha, ident, args.max_steps))
    return jobs, scene_of, chosen, default


def main() -> None:
    args = _args()
    try:
        jobs, scene_of, chosen, default = _plan(args)
    except CoreError as exc:
        sys.exit(f"real_data_closed_loop: {exc}")
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        rows = list(pool.map(_episode, jobs, chunksize=1))
    for r in rows:
        r["scene"] = scene_of[r["scenario"]]
        r["held_out_scene"] = r["scene"] if r["predictor"] == "ethucy" else None
    out = {
        "benchmark": "real_data_closed_loop",
        "matrix": args.matrix,
        "provenance": "leave-one-scene-out: each replay scene's ETH/UCY model held that scene out of its training "
        "(neither train nor val; read from the checkpoint's recorded scenes)",
        "wall_s": round(time.perf_counter() - t0, 1),
        **summarize(rows, scene_of),
        "ethucy_models": {scene: lin.provenance() for scene, lin in sorted(chosen.items())},
        "default_model": default,
        "episode_rows": rows,
    }
    if args.json:
        print(json.dumps(out))
        return
    print(f"{out['episodes']} paired episodes on {len(chosen)} replay scenes ({args.matrix})")
    for w, r in out["predictors"].items():
        lo, hi = r["success_interval"]
        clo, chi = r["collision_interval"]
        print(
            f"{w:>8}: success {r['success']}/{out['episodes']} = {r['success_rate']:.3f} [{lo:.3f}, {hi:.3f}], "
            f"collisions {r['collisions']} = {r['collision_rate']:.3f} [{clo:.3f}, {chi:.3f}], timeouts {r['timeouts']}"
        )
    for k, pair in out["paired"].items():
        for what, r in pair.items():
            a, b = list(r.values())[:2]
            print(f"{k} {what}: discordant {a} : {b}, McNemar p = {r['mcnemar_p']:.3g}")
    for scene, lin in out["ethucy_models"].items():
        print(
            f"{scene}: {lin['model_id']} (sha256 {lin['sha256'][:12]}, holds out {', '.join(lin['held_out'])})"
        )


if __name__ == "__main__":
    main()
