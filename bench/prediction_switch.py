"""The prediction switch, as CrowdNav++ exposes it: one planner, four forecasts, the same episodes.

The predictive planner with its CrowdNav config (``configs/planners/crowdnav/predictive.yaml``) runs every chosen
test case of each CrowdNav suite (``--suites crowdnav``: circle crossing, square crossing, CrowdNav++ no rand and
rand; the originals' test cases in order) once per forecast:

- ``static``: everyone stays where they are (CrowdNav++'s prediction ``none``);
- ``cv``: constant velocity;
- ``learned``: a trained model (``--checkpoint``; default the one ``configs/pipelines/crowdnav.yaml`` trains);
- ``oracle``: the truth (``core.predict.live_oracle``): at every decision the crowd's next 2.5 s from a copy of
  the simulator's own crowd, stepped with the robot standing where it is (exact on these suites, checked by
  ``tests/unit/predict/test_live_oracle.py``);
- ``oracle_cv_spread`` (not run by default): the truth's positions with constant velocity's spread, so that against
  ``cv`` only the positions differ and against ``oracle`` only the spread;
- ``recorded`` (not run by default): the recorded oracle (``core.predict.oracle``), the crowd recorded around a
  robot standing at its start. These humans never see the robot, but a new goal or a replacement human is drawn
  clear of the robot where it then is, so the recording parts from the episode at the first such draw.

Per suite and forecast: success [Wilson 95 %] / collision / timeout counts and rates, the mean navigation time of
the successes, and the forecasts' own error against where the humans then were (mean over every forecast step and
at the last step; a human replaced in between is left out); per suite, each forecast against ``cv`` on the same
episodes: discordant pairs (cv-only successes : its-only successes) and McNemar's exact p. ``--rows`` keeps every
episode as one JSON line as it finishes; a rerun with the same file runs only the missing episodes.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from functools import cache
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from foresight.core.evaluation.stats import mcnemar_p, wilson_interval  # noqa: E402

SUITES = REPO / "configs" / "scenarios" / "crowdnav"
CROWDNAV = ("circle_crossing", "square_crossing", "crowdnavpp_no_rand", "crowdnavpp_rand")
PLANNER = REPO / "configs" / "planners" / "crowdnav" / "predictive.yaml"
CHECKPOINT = REPO / "runs" / "crowdnav" / "train" / "model.pt"
FORECASTS = ("static", "cv", "learned", "oracle")
KNOWN = FORECASTS + ("oracle_cv_spread", "recorded")
REFERENCE = "cv"
MAX_SPEED = 2.0  #: [m/s] above any human's: a larger jump between two states is a replacement, not a walk


# ------------------------------------------------------------------------------------------ the table


def summarize(rows: Iterable[dict[str, Any]], forecasts: Sequence[str], reference: str = REFERENCE) -> dict:
    """Suite -> per forecast counts and rates, and each forecast against ``reference`` on the episodes both ran.

    ``rows``: one per episode, ``{suite, seed, forecast, outcome, nav_time_s, ...}``; an episode's outcome is
    ``success``, ``collision_pedestrian``, ``collision_static`` or ``timeout``.
    """
    by: dict[str, dict[str, dict[int, dict[str, Any]]]] = {}
    for r in rows:
        by.setdefault(r["suite"], {}).setdefault(r["forecast"], {})[int(r["seed"])] = r
    out: dict[str, Any] = {}
    for suite, runs in by.items():
        table: dict[str, Any] = {"forecasts": {}, "paired": {}}
        for f in forecasts:
            eps = runs.get(f, {})
            n = len(eps)
            if not n:
                continue
            outcomes = [e["outcome"] for e in eps.values()]
            won = outcomes.count("success")
            times = [e["nav_time_s"] for e in eps.values() if e["outcome"] == "success"]
            errs = [e for e in eps.values() if e.get("ade_m") is not None]
            table["forecasts"][f] = {
                "episodes": n,
                "success": won,
                "collisions": outcomes.count("collision_pedestrian") + outcomes.count("collision_static"),
                "timeouts": outcomes.count("timeout"),
                "success_rate": won / n,
                "success_interval": list(wilson_interval(won, n)),
                "collision_rate": (
                    outcomes.count("collision_pedestrian") + outcomes.count("collision_static")
                )
                / n,
                "timeout_rate": outcomes.count("timeout") / n,
                "nav_time_s": sum(times) / len(times) if times else None,
                "forecast_error": {
                    "ade_m": _mean(e["ade_m"] for e in errs),
                    "fde_m": _mean(e["fde_m"] for e in errs),
                },
            }
        ref = runs.get(reference, {})
        for f in forecasts:
            if f == reference or f not in runs or not ref:
                continue
            both = sorted(set(ref) & set(runs[f]))
            ref_only = sum(1 for s in both if ref[s]["outcome"] == "success" != runs[f][s]["outcome"])
            own_only = sum(1 for s in both if runs[f][s]["outcome"] == "success" != ref[s]["outcome"])
            table["paired"][f"{f}_vs_{reference}"] = {
                "episodes": len(both),
                f"{reference}_only": ref_only,
                f"{f}_only": own_only,
                "mcnemar_p": mcnemar_p(ref_only, own_only),
            }
        out[suite] = table
    return out


def _mean(values: Iterable[float | None]) -> float | None:
    kept = [v for v in values if v is not None]
    return sum(kept) / len(kept) if kept else None


def text_table(summary: dict[str, Any], reference: str = REFERENCE) -> str:
    lines = []
    for suite, table in summary.items():
        lines.append(suite)
        for f, r in table["forecasts"].items():
            lo, hi = r["success_interval"]
            t = f"{r['nav_time_s']:.2f} s" if r["nav_time_s"] is not None else "-"
            err = r["forecast_error"]
            e = f", ADE {err['ade_m']:.3f} m" if err["ade_m"] is not None else ""
            e += f" / FDE {err['fde_m']:.3f} m" if err["fde_m"] is not None else ""
            pair = table["paired"].get(f"{f}_vs_{reference}")
            p = (
                f", vs {reference} {pair[f'{reference}_only']} : {pair[f'{f}_only']} p = {pair['mcnemar_p']:.3g}"
                if pair
                else ""
            )
            lines.append(
                f"  {f:>8}: {r['success_rate']:.3f} [{lo:.3f}-{hi:.3f}] / {r['collision_rate']:.3f} / "
                f"{r['timeout_rate']:.3f}, {t} (n = {r['episodes']}){e}{p}"
            )
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------ one episode


@cache
def _suite(name: str):  # noqa: ANN202
    from foresight.core.scenarios.loader import load_matrix

    return load_matrix(SUITES / f"{name}.yaml").scenarios[0]


@cache
def _planner_config() -> dict[str, Any]:
    import yaml

    return yaml.safe_load(PLANNER.read_text())["config"]


@cache
def _learned(path: str):  # noqa: ANN202
    from foresight.core.predict.nn.checkpoint import load_predictor

    return load_predictor(Path(path))


class _Kept:
    """A forecaster that keeps each forecast it hands the planner, by the step it was made at."""

    def __init__(self, inner: Any):
        self.inner, self.kept, self.seen, self._step = inner, {}, {}, 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)

    def observe(self, obs: Any) -> None:
        self._step = int(obs.step)
        self.seen[self._step] = dict(zip(obs.ped_ids.tolist(), obs.ped_positions.copy(), strict=True))
        self.inner.observe(obs)

    def forecast(self) -> Any:
        fc = self.inner.forecast()
        self.kept[self._step] = fc
        return fc

    def update(self, obs: Any) -> Any:
        self.observe(obs)
        return self.forecast()


def forecast_error(
    kept: dict[int, Any], seen: dict[int, dict[int, Any]], dt: float
) -> tuple[float, float] | None:
    """(mean error over every forecast step, mean error at the last step) [m] against the states then seen; a
    human whose later state lies farther than ``MAX_SPEED`` could walk (replaced in between) is left out."""
    import numpy as np

    all_err, last_err = [], []
    for step, fc in kept.items():
        now = seen.get(step)
        if now is None:
            continue
        for i, pid in enumerate(np.asarray(fc.ped_ids).tolist()):
            if pid not in now:
                continue
            for k, t in enumerate(np.asarray(fc.times, dtype=float)):
                later = seen.get(step + int(round(t / dt)), {}).get(pid)
                if later is None or np.hypot(*(later - now[pid])) > MAX_SPEED * t + 0.5:
                    continue
                e = float(np.hypot(*(np.asarray(fc.positions[i, k]) - later)))
                all_err.append(e)
                if k == len(fc.times) - 1:
                    last_err.append(e)
    if not all_err:
        return None
    return float(np.mean(all_err)), float(np.mean(last_err)) if last_err else None


def run_one(job: tuple[str, int, str, str, int | None]) -> dict[str, Any]:
    """One episode (runs in a worker process): the row ``summarize`` reads."""
    from foresight.core.planners.predictive.config import PredictivePlannerConfig
    from foresight.core.planners.predictive.planner import PredictivePlanner
    from foresight.core.planners.registry import make_forecaster
    from foresight.core.predict.live_oracle import LiveOracleForecaster
    from foresight.core.predict.oracle import OracleForecaster
    from foresight.core.sim.episode import run_episode
    from foresight.core.sim.simulator import Simulator

    suite, seed, which, checkpoint, max_steps = job
    sc = _suite(suite)
    sim = Simulator()
    if which == "oracle":
        inner = LiveOracleForecaster(sim)
    elif which == "oracle_cv_spread":
        from foresight.core.predict.uncertainty import CV_SIGMA

        inner = LiveOracleForecaster(sim, sigma=CV_SIGMA)
    elif which == "recorded":
        inner = OracleForecaster.for_episode(sc, seed, max_steps)
    else:
        inner = make_forecaster(_learned(checkpoint) if which == "learned" else which)
    kept = _Kept(inner)

    def note(obs, cmd, events, diag) -> None:  # noqa: ANN001
        kept.seen[int(obs.step)] = dict(zip(obs.ped_ids.tolist(), obs.ped_positions.copy(), strict=True))

    planner = PredictivePlanner(PredictivePlannerConfig.model_validate(_planner_config()), kept)
    res = run_episode(sc, seed, planner, max_steps=max_steps, on_step=note, simulator=sim)
    dt = float(sc.scenario.simulation_config.dt)
    err = forecast_error(kept.kept, kept.seen, dt)
    return {
        "suite": suite,
        "seed": int(seed),
        "forecast": which,
        "outcome": res.outcome,
        "steps": int(res.steps),
        "nav_time_s": res.steps * dt,
        "min_clearance_m": res.min_clearance,
        "ade_m": None if err is None else err[0],
        "fde_m": None if err is None else err[1],
        "source": getattr(inner, "source", which),
        "wall_s": round(res.wall_s, 2),
    }


# ------------------------------------------------------------------------------------------ main


def _test_cases(suite: str, n: int | None) -> list[int]:
    """The suite's first ``n`` test cases (all: None), in order."""
    seeds = [int(s) for s in _suite(suite).scenario.seeds]
    return seeds[:n] if n else seeds


def _read_rows(path: Path | None) -> list[dict[str, Any]]:
    if path is None or not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--suites", default="crowdnav", help=f"'crowdnav' (all four) or a comma list of {', '.join(CROWDNAV)}"
    )
    ap.add_argument("--forecasts", default=",".join(FORECASTS), help=f"comma list of {', '.join(KNOWN)}")
    ap.add_argument("--checkpoint", default=str(CHECKPOINT), help="the learned model (.pt)")
    ap.add_argument(
        "--episodes", type=int, default=None, help="the first N test cases of each suite (default: all)"
    )
    ap.add_argument("--max-steps", type=int, default=None, help="horizon override (smoke runs only)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument(
        "--rows", default=None, help="JSON-lines file of every episode (appended; a rerun resumes)"
    )
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args()

    suites = list(CROWDNAV) if args.suites == "crowdnav" else [s.strip() for s in args.suites.split(",")]
    bad = [s for s in suites if s not in CROWDNAV]
    if bad:
        sys.exit(f"--suites: unknown suite {bad[0]!r}, expected crowdnav or some of {', '.join(CROWDNAV)}")
    forecasts = [f.strip() for f in args.forecasts.split(",")]
    bad = [f for f in forecasts if f not in KNOWN]
    if bad:
        sys.exit(f"--forecasts: unknown forecast {bad[0]!r}, expected some of {', '.join(KNOWN)}")
    if "learned" in forecasts:
        if not Path(args.checkpoint).is_file():
            sys.exit(
                f"--checkpoint: {args.checkpoint} not found; train it with `foresight pipeline run --local -f "
                "configs/pipelines/crowdnav.yaml --out runs/crowdnav`, or leave 'learned' out of --forecasts"
            )
        from foresight.core.errors import CoreError

        try:
            _learned(args.checkpoint).timebase.stride(0.25)
        except CoreError as exc:
            sys.exit(f"--checkpoint: {args.checkpoint}: {exc} (the CrowdNav suites step 0.25 s)")
    rows_path = Path(args.rows) if args.rows else None
    rows = _read_rows(rows_path)
    done = {(r["suite"], int(r["seed"]), r["forecast"]) for r in rows}
    jobs = []
    for suite in suites:
        for seed in _test_cases(suite, args.episodes):
            for f in forecasts:
                if (suite, int(seed), f) not in done:
                    jobs.append((suite, int(seed), f, args.checkpoint, args.max_steps))
    t0 = time.perf_counter()
    sink = rows_path.open("a") if rows_path else None
    try:
        with ProcessPoolExecutor(max_workers=args.workers) as pool:
            for row in pool.map(run_one, jobs, chunksize=1):
                rows.append(row)
                if sink:
                    sink.write(json.dumps(row) + "\n")
                    sink.flush()
    finally:
        if sink:
            sink.close()
    wanted = {(s, int(seed)) for s in suites for seed in _test_cases(s, args.episodes)}
    rows = [r for r in rows if (r["suite"], int(r["seed"])) in wanted and r["forecast"] in forecasts]
    summary = summarize(rows, forecasts)
    out = {
        "benchmark": "prediction_switch",
        "planner": str(PLANNER.relative_to(REPO)),
        "checkpoint": args.checkpoint if "learned" in forecasts else None,
        "max_steps": args.max_steps,
        "episodes_run_now": len(jobs),
        "wall_s": round(time.perf_counter() - t0, 1),
        "cpus": os.cpu_count(),
        "suites": summary,
    }
    if args.json:
        print(json.dumps(out))
    else:
        print(text_table(summary))


if __name__ == "__main__":
    main()
