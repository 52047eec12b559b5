"""Predictive planner decision time: ms per ``plan`` call with 4, 16 and 50 pedestrians, cv and learned.

Closed loop in the simulator on an open map with two pillars and exactly N pedestrians (crowded
zone over the whole map, so pedestrians stay around the robot), the predictive planner driving.
Only ``plan`` is timed (forecaster call included), as wall time (p50_ms, p95_ms) and as this
process's CPU time (cpu_*: less sensitive to other processes on a shared machine); the first decisions of each
episode warm up caches (static distance field) and are reported separately as ``first_ms``; ``near_field_share``
and ``p50_near_ms`` / ``p50_far_ms`` split the decisions by the planner's near field. An episode that ends is
reset and stepping continues until ``--decisions`` decisions were timed. Targets: p50 <= 2 ms and
p95 <= 5 ms at 16 pedestrians. ``--json`` prints ONE JSON object with ``entries``
[{pedestrians, predictor, p50_ms, p95_ms, ...}]; the learned rows use ``--checkpoint`` (default: the
shipped default predictor, model/predictor-sim-default.pt).

``--external`` adds ``external`` rows: the per-step round trip of the external-planner protocol (observation as
a JSON line to the process, command back; core.planners.external) with the reference client
examples/external_planner.py, whose own work (a loop over the pedestrians) is included. Target: p50 <= 0.3 ms.

``--modes 1 6``: the K axis. K = 1 rows are the cv (and learned) rows above; each K > 1 adds a ``modes`` row: the
example predictor plug-in (examples/predictor_plugin: constant velocity with sampled heading noise) with K modes on
the planner's own time base, every mode weighed by the cost. Target: p50 <= 2.5 ms at K = 6, 16 pedestrians.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
DEFAULT_CHECKPOINT = REPO / "model" / "predictor-sim-default.pt"
sys.path.insert(0, str(REPO))

from foresight.core.maps.model import MapDef, Route, Zone  # noqa: E402
from foresight.core.planners.registry import make_planner  # noqa: E402
from foresight.core.scenarios.model import ResolvedScenario, Scenario, SimulationConfig  # noqa: E402
from foresight.core.sim.planner import EpisodeInfo  # noqa: E402
from foresight.core.sim.simulator import Simulator  # noqa: E402


def scenario(n: int) -> ResolvedScenario:
    """A 30 x 20 m map, two pillars, a robot route across it and exactly ``n`` pedestrians over the map."""
    m = MapDef(
        name=f"latency_{n}",
        width=30.0,
        height=20.0,
        obstacles=(((10, 6), (12, 6), (12, 8), (10, 8)), ((18, 12), (20, 12), (20, 14), (18, 14))),
        robot_spawn_zones=(Zone.from_rect(1, 9, 2, 2),),
        robot_goal_zones=(Zone.from_rect(27, 9, 2, 2),),
        robot_routes=(Route(spawn_id=0, goal_id=0, waypoints=((2, 10), (28, 10))),),
        ped_crowded_zones=(Zone.from_rect(3, 2, 24, 16),),
    )
    sim = SimulationConfig(population_size=n, max_episode_steps=400, max_peds_per_group=1)
    return ResolvedScenario(
        scenario=Scenario(name=f"latency_{n}", map_id=m.name, simulation_config=sim), map=m
    )


def measure(n: int, model, decisions: int, seed: int = 0, planner=None) -> dict:
    """Time ``decisions`` plan() calls (after the first of each episode) with n pedestrians."""
    scen = scenario(n)
    planner = planner or make_planner("predictive", None, model=model)
    sim = Simulator()
    times: list[float] = []
    cpu: list[float] = []
    first: list[float] = []
    peds: list[int] = []
    near: list[bool] = []  #: the timed decisions' near-field flag (denser candidate sets: the slower ones)
    while len(times) < decisions:
        obs = sim.reset(scen, seed)
        planner.reset(
            EpisodeInfo(
                scenario=scen, seed=seed, dt=sim.dt, robot_radius=sim.limits.radius, ped_radius=sim.ped_radius
            )
        )
        seed += 1
        k = 0
        while len(times) < decisions:
            t0, c0 = time.perf_counter(), time.process_time()
            cmd = planner.plan(obs)
            if k == 0:
                first.append(time.perf_counter() - t0)
            else:
                times.append(time.perf_counter() - t0)
                cpu.append(time.process_time() - c0)
                near.append(bool((planner.diagnostics or {}).get("near_field")))
            peds.append(len(obs.ped_ids))
            k += 1
            obs, ev = sim.step(cmd)
            if ev.done:
                break
    ms = np.asarray(times) * 1e3
    cpu_ms = np.asarray(cpu) * 1e3
    source = (
        "external" if planner.name == "external" else planner.diagnostics["forecast_source"].split(":")[0]
    )
    return {
        "pedestrians": n,
        "predictor": source,
        "modes": int((planner.diagnostics or {}).get("forecast_modes", 1)),
        "p50_ms": round(float(np.percentile(ms, 50)), 3),
        "p95_ms": round(float(np.percentile(ms, 95)), 3),
        "mean_ms": round(float(ms.mean()), 3),
        "cpu_p50_ms": round(float(np.percentile(cpu_ms, 50)), 3),
        "cpu_p95_ms": round(float(np.percentile(cpu_ms, 95)), 3),
        "first_ms": round(float(np.max(first)) * 1e3, 3),
        "decisions": len(ms),
        "observed_pedestrians": int(np.median(peds)),
        **_near_far(ms, np.asarray(near)),
    }


def _near_far(ms: np.ndarray, near: np.ndarray) -> dict:
    """The share of near-field decisions and the p50 of each kind: a p50 moves with that share as much as with
    the code (the near field evaluates about 1.5x the candidates)."""
    out = {"near_field_share": round(float(near.mean()), 3) if len(near) else 0.0}
    for name, part in (("near", ms[near]), ("far", ms[~near])):
        out[f"p50_{name}_ms"] = round(float(np.percentile(part, 50)), 3) if len(part) else None
    return out


def external_planner():
    """The reference client as an operator-configured external planner."""
    import os

    from foresight.core.planners.external import ENV

    os.environ[ENV] = json.dumps(
        {"reference": [sys.executable, str(REPO / "examples" / "external_planner.py")]}
    )
    return make_planner("external", {"command": "reference"})


def modes_planner(k: int):
    """The predictive planner driven by the example plug-in with ``k`` heading-noise modes at the planner's step."""
    sys.path.insert(0, str(REPO / "examples" / "predictor_plugin"))
    from foresight_cv_noise import ConstantVelocityHeadingNoise

    tb = {"dt": 0.2, "history": 5, "horizon": 12}
    return make_planner("predictive", None, model=ConstantVelocityHeadingNoise(modes=k, timebase=tb))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--pedestrians", type=int, nargs="+", default=[4, 16, 50])
    ap.add_argument("--decisions", type=int, default=400)
    ap.add_argument(
        "--checkpoint",
        type=Path,
        default=DEFAULT_CHECKPOINT if DEFAULT_CHECKPOINT.is_file() else None,
        help="learned model checkpoint (default: the shipped default predictor)",
    )
    ap.add_argument(
        "--external", action="store_true", help="also time the external-planner protocol round trip"
    )
    ap.add_argument("--external-only", action="store_true", help="time only the external-planner protocol")
    ap.add_argument(
        "--modes", type=int, nargs="+", default=[1], help="forecast modes K (K > 1: the example plug-in)"
    )
    args = ap.parse_args()
    args.external |= args.external_only
    if args.external_only:
        args.checkpoint = None
    models: list = [] if args.external_only else ["cv"]
    if args.checkpoint:
        import torch

        from foresight.core.predict.nn.checkpoint import load_predictor

        torch.set_num_threads(1)  # one decision per core, as in the evaluation's worker processes
        models.append(load_predictor(args.checkpoint))
    entries = [measure(n, model, args.decisions) for model in models for n in args.pedestrians]
    targets = {"pedestrians": 16, "p50_ms": 2.0, "p95_ms": 5.0}
    multi = [k for k in args.modes if k > 1]
    entries += [
        measure(n, None, args.decisions, planner=modes_planner(k)) for k in multi for n in args.pedestrians
    ]
    if multi:
        targets["p50_ms_6_modes"] = 2.5
    if args.external:
        entries += [measure(n, None, args.decisions, planner=external_planner()) for n in args.pedestrians]
        targets["external_p50_ms"] = 0.3
    result = {"benchmark": "planner_latency", "targets": targets, "entries": entries}
    if args.json:
        print(json.dumps(result))
    else:
        for e in entries:
            print(
                f"{e['predictor']:>18} K={e['modes']:<2} {e['pedestrians']:>3} peds  p50 {e['p50_ms']:.2f} ms  p95 {e['p95_ms']:.2f} ms"
                f"  (cpu p50 {e['cpu_p50_ms']:.2f}, p95 {e['cpu_p95_ms']:.2f})"
            )


if __name__ == "__main__":
    main()
