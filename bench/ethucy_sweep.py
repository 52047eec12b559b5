"""ETH/UCY training variants side by side: every (variant, fold) pair is one ``predict-eval --train`` run of that fold,
spread over worker processes (CPU workers with one thread each, and optionally CUDA workers on a GPU machine).

A variant is the training config with some fields overridden (and ``reverse_train``, the stage's own key, beside
them). Prints per variant the 5-fold average ADE/FDE (the number the ETH/UCY target reads), each fold's, and
constant velocity's on the same samples.
Usage: python bench/ethucy_sweep.py --ethucy ../shared/reference/ethucy [--config configs/training/ethucy.yaml]
         [--variant NAME='{"batch_size": 512}' ...] [--workers 2] [--gpu-workers 0] [--folds eth,hotel] [--json]
Without --variant it runs the config as it is (variant ``config``).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import tempfile
import time
from pathlib import Path

from foresight.core.predict.ethucy import FOLDS
from foresight.core.training.predict_eval import FILE_KEYS


def run_one(
    args: tuple[str, dict, str, str, str, str],
) -> dict:  # (variant, stage, fold, root, device, workdir)
    """One fold of one variant, trained and scored in-process (the same stage ``foresight predict-eval`` runs);
    ``stage``: the stage's values, ``train`` and its own ``FILE_KEYS`` (``stage_values``)."""
    name, stage, fold, root, device, workdir = args
    if device == "cpu":
        os.environ["CUDA_VISIBLE_DEVICES"] = ""
    from foresight.core.runtime.context import StageContext
    from foresight.core.training.predict_eval import PredictEvalConfig, run_predict_eval

    started = time.time()
    work = Path(workdir) / name / fold
    work.mkdir(parents=True, exist_ok=True)
    config = PredictEvalConfig(
        **{**stage, "train": {**stage["train"], "device": device, "threads": 1}}, ethucy=root, folds=[fold]
    )
    result = run_predict_eval(config, StageContext(workdir=work, local_files=True)).folds[fold]
    return {
        "variant": name,
        "fold": fold,
        "device": device,
        "seconds": round(time.time() - started, 1),
        "ade": result.ade,
        "fde": result.fde,
        "cv_ade": result.cv_ade,
        "cv_fde": result.cv_fde,
        "samples": result.samples,
        **(
            {  # a model with modes: minADE_K over its modes (K = best_of) and mode 0's numbers
                "best_of": result.best_of,
                "min_ade": result.min_ade,
                "min_fde": result.min_fde,
                "first_ade": result.first_ade,
                "first_fde": result.first_fde,
            }
            if result.modes > 1
            else {}
        ),
    }


def stage_values(values: dict) -> dict:
    """A variant's merged values as the stage's: the training config's fields under ``train``, ``FILE_KEYS`` beside."""
    return {
        "train": {k: v for k, v in values.items() if k not in FILE_KEYS},
        **{k: values[k] for k in FILE_KEYS if k in values},
    }


def _worker(jobs, results, device: str) -> None:
    while True:
        job = jobs.get()
        if job is None:
            return
        try:
            results.put(run_one((*job[:4], device, job[4])))
        except Exception as exc:  # noqa: BLE001 - reported per job, the sweep goes on
            results.put({"variant": job[0], "fold": job[2], "error": f"{type(exc).__name__}: {exc}"})


def table(rows: list[dict], folds: list[str]) -> dict[str, dict]:
    """Per variant with every fold scored: 5-fold averages and each fold's ADE/FDE."""
    out = {}
    for name in dict.fromkeys(r["variant"] for r in rows):
        done = {r["fold"]: r for r in rows if r["variant"] == name and "ade" in r}
        if set(done) != set(folds):
            out[name] = {"incomplete": sorted(set(folds) - set(done))}
            continue
        keys = ("ade", "fde", "cv_ade", "cv_fde", "min_ade", "min_fde", "first_ade", "first_fde")
        out[name] = {
            **{
                k: round(sum(done[f][k] for f in folds) / len(folds), 4)
                for k in keys
                if all(done[f].get(k) is not None for f in folds)
            },
            "folds": {f: [round(done[f]["ade"], 4), round(done[f]["fde"], 4)] for f in folds},
            "seconds": round(sum(done[f]["seconds"] for f in folds), 1),
        }
    return out


def main() -> None:
    import yaml

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ethucy", required=True, help="ETH/UCY root (<fold>/train|val|test)")
    ap.add_argument("--config", default="configs/training/ethucy.yaml")
    ap.add_argument("--variant", action="append", default=[], metavar="NAME=JSON")
    ap.add_argument("--folds", default=",".join(FOLDS))
    ap.add_argument("--workers", type=int, default=2, help="CPU worker processes (one torch thread each)")
    ap.add_argument("--gpu-workers", type=int, default=0, help="worker processes training on CUDA")
    ap.add_argument("--out", help="work folder (default: a temporary one)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    raw = yaml.safe_load(Path(args.config).read_text())
    base = {**raw.get("train", raw), **{k: raw[k] for k in FILE_KEYS if "train" in raw and k in raw}}
    variants = {"config": {}} if not args.variant else {}
    for item in args.variant:
        name, _, overrides = item.partition("=")
        try:
            variants[name] = json.loads(overrides or "{}")
        except json.JSONDecodeError as exc:
            raise SystemExit(f"--variant {name}: overrides are not JSON ({exc.msg})") from None
    if not Path(args.ethucy).is_dir():
        raise SystemExit(
            f"--ethucy {args.ethucy}: not a folder (expected the ETH/UCY root with <fold>/train|val|test)"
        )
    folds = args.folds.split(",")
    if unknown := set(folds) - set(FOLDS):
        raise SystemExit(f"--folds: unknown {sorted(unknown)} (expected some of {', '.join(FOLDS)})")
    workdir = args.out or tempfile.mkdtemp(prefix="ethucy_sweep_")
    ctx = mp.get_context("spawn")
    jobs, results = ctx.Queue(), ctx.Queue()
    todo = [
        (name, stage_values({**base, **over}), fold, args.ethucy, workdir)
        for name, over in variants.items()
        for fold in folds
    ]
    devices = ["cuda"] * args.gpu_workers + ["cpu"] * args.workers
    for job in todo:
        jobs.put(job)
    for _ in devices:
        jobs.put(None)
    procs = [ctx.Process(target=_worker, args=(jobs, results, d)) for d in devices]
    for p in procs:
        p.start()
    rows = []
    for _ in todo:
        rows.append(results.get())
        if not args.json:
            print(json.dumps(rows[-1]), flush=True)
    for p in procs:
        p.join()
    report = {
        "benchmark": "ethucy_sweep",
        "config": args.config,
        "variants": variants,
        "folds": folds,
        "table": table(rows, folds),
        "errors": [r for r in rows if "error" in r],
    }
    print(json.dumps(report, indent=None if args.json else 1))


if __name__ == "__main__":
    main()
