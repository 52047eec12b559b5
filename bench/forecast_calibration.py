"""Forecast spread per predictor: fits sigma(t)^2 = sigma0^2 + (sigma_v t)^2 to forecast errors (core.predict.uncertainty).

Rolls out the stress suite's TRAINING seeds (``configs/seeds/stress_train.yaml``, never evaluation seeds)
with the predictive planner on constant-velocity forecasts, cuts the traces into samples with the ONE
feature function, and fits each predictor's per-axis error variance per horizon step. Prints ONE JSON
object (``--json``): per predictor the fitted sigma0 / sigma_v, the RMS error per step and the share of
errors inside 1 and 2 fitted sigmas (a Gaussian gives 0.39 / 0.86 for the 2-D radius). A model with a sigma
head (``has_sigma``) also gets ``own_sigma``: the same shares and the mean NLL under the spread it predicts.
The default model is trained on the training seeds themselves: ``--seed-offset 100000`` rolls out seeds
nobody trains or evaluates on (held out), where the coverage of its own spread means something.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from foresight.core.errors import CoreError  # noqa: E402
from foresight.core.planners.registry import make_planner  # noqa: E402
from foresight.core.predict.features import current_index  # noqa: E402
from foresight.core.predict.predictor import ConstantVelocityPredictor  # noqa: E402
from foresight.core.predict.samples import samples_from_trace  # noqa: E402
from foresight.core.predict.timebase import PLANNER_TIMEBASE  # noqa: E402
from foresight.core.predict.uncertainty import GrowingSigma  # noqa: E402
from foresight.core.scenarios.loader import load_matrix  # noqa: E402
from foresight.core.scenarios.seeds import load_seed_manifest  # noqa: E402
from foresight.core.sim.episode import run_episode  # noqa: E402
from foresight.core.training.collect import _Recorder  # noqa: E402


def errors(predictor, samples, near: float | None, own_sigma: bool = False):
    """(M, T, 2) forecast minus truth of every (sample, pedestrian) with its whole horizon observed,
    only those within ``near`` metres of the robot now when given (the ones the planner's terms weigh);
    with ``own_sigma`` also the model's predicted per-axis std (M, T) of the same points."""
    if own_sigma:
        outs = [predictor.predict_dist(s.state, s.mask) for s in samples]
        pred, sigma = np.concatenate([o[0] for o in outs]), np.concatenate([o[1] for o in outs])
    else:
        pred, sigma = np.concatenate([predictor.predict(s.state, s.mask) for s in samples]), None
    target = np.concatenate([s.target for s in samples])
    keep = np.concatenate([(s.target_mask > 0).all(axis=-1) for s in samples])  # (S, N)
    if near is not None:
        px = current_index(PLANNER_TIMEBASE.history, "px")
        state = np.concatenate([s.state for s in samples])
        keep &= np.hypot(state[..., px], state[..., px + 1]) <= near
    return ((pred - target)[keep], sigma[keep]) if own_sigma else (pred - target)[keep]


def coverage(err: np.ndarray, sigma: np.ndarray) -> dict[str, float]:
    """Shares of 2-D errors within 1 and 2 per-axis sigmas (calibrated: 0.393 / 0.865) and the mean NLL per point."""
    sq = np.sum(err**2, axis=-1)
    radius = np.sqrt(sq) / sigma
    nll = np.log(2 * np.pi) + 2 * np.log(sigma) + sq / (2 * sigma**2)
    return {
        "within_1_sigma": round(float(np.mean(radius <= 1.0)), 3),
        "within_2_sigma": round(float(np.mean(radius <= 2.0)), 3),
        "nll": round(float(np.mean(nll)), 3),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--matrix", default=str(REPO / "configs/scenarios/stress.yaml"))
    ap.add_argument("--seeds", default=str(REPO / "configs/seeds/stress_train.yaml"))
    ap.add_argument("--per-scenario", type=int, default=2, help="training seeds per scenario")
    ap.add_argument("--scenarios", help="comma-separated scenario names (default: all)")
    ap.add_argument("--max-steps", type=int, help="horizon override (default: the scenario horizons)")
    ap.add_argument("--checkpoint", default=str(REPO / "model/predictor-sim-default.pt"))
    ap.add_argument(
        "--near", type=float, default=4.0, help="also fit on pedestrians this close to the robot [m]"
    )
    ap.add_argument(
        "--seed-offset",
        type=int,
        default=0,
        help="add this to every training seed (100000: held-out seeds, neither trained nor evaluated on)",
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    matrix = load_matrix(args.matrix)
    manifest = load_seed_manifest(args.seeds, matrix)
    try:
        chosen = (
            [matrix.get(n.strip()) for n in args.scenarios.split(",")] if args.scenarios else matrix.scenarios
        )
    except CoreError as exc:
        sys.exit(f"forecast_calibration: --scenarios: {exc}")
    tb = PLANNER_TIMEBASE
    samples = []
    for scen in chosen:
        for seed in list(manifest.seeds.get(scen.name, ()))[: args.per_scenario]:
            seed += args.seed_offset
            policy = _Recorder(make_planner("predictive", None, model="cv"))
            res = run_episode(scen, seed, policy, max_steps=args.max_steps)
            samples.append(samples_from_trace(res.trace, tb, 12, policy.waypoint_array(res.steps)))
    samples = [s for s in samples if len(s)]
    if not samples:
        sys.exit(
            "forecast_calibration: the episodes gave no samples (a horizon shorter than history + forecast?)"
        )
    predictors = {"constant_velocity": ConstantVelocityPredictor(tb)}
    if args.checkpoint and Path(args.checkpoint).is_file():
        import torch

        from foresight.core.predict.nn.checkpoint import load_predictor

        torch.set_num_threads(1)
        predictors["learned"] = load_predictor(args.checkpoint)
    out = {
        "benchmark": "forecast_calibration",
        "matrix": args.matrix,
        "seeds": args.seeds,
        "per_scenario": args.per_scenario,
        "scenarios": [s.name for s in chosen],
        "max_steps": args.max_steps,
        "seed_offset": args.seed_offset,
        "times": tb.times.tolist(),
        "predictors": {},
    }
    for name, predictor in predictors.items():
        for subset, near in (("all", None), (f"within_{args.near:g}_m", args.near)):
            own = bool(getattr(predictor, "has_sigma", False))
            err, sigma = (
                errors(predictor, samples, near, own) if own else (errors(predictor, samples, near), None)
            )
            if not len(err):  # nothing to fit (no pedestrian that near): the count alone, no NaN
                out["predictors"].setdefault(name, {})[subset] = {"pedestrian_horizons": 0}
                continue
            fit = GrowingSigma.fit(tb.times, err)
            row = {
                "sigma0": round(fit.sigma0, 4),
                "sigma_v": round(fit.sigma_v, 4),
                "pedestrian_horizons": len(err),
                "rms_per_axis": np.sqrt(np.mean(err**2, axis=(0, 2))).round(4).tolist(),
                **coverage(err, np.broadcast_to(fit(tb.times), err.shape[:2])),
            }
            if own:
                row["own_sigma"] = {
                    **coverage(err, sigma),
                    "mean_sigma_per_step": sigma.mean(axis=0).round(4).tolist(),
                }
            out["predictors"].setdefault(name, {})[subset] = row
    print(json.dumps(out) if args.json else json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
