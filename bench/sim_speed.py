"""Simulator speed: ms per step on open maps with N pedestrians and on the 23 reference scenarios.

Times ``Simulator.step`` only (observation building and trace recording included, the planner
not); commands come from the goal-seeking controller. An open map's episode lasts the timed steps (fewer where
the trace limit requires it), so its trace is no larger than the run needs; an episode that ends is reset (untimed)
and stepping continues. Each case reports the median over repeats. ``--json`` prints ONE JSON object.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from foresight.core.maps.model import MapDef, Route, Zone  # noqa: E402
from foresight.core.planners.goal import GoalSeeking  # noqa: E402
from foresight.core.scenarios.model import ResolvedScenario, Scenario, SimulationConfig  # noqa: E402
from foresight.core.sim.planner import EpisodeInfo  # noqa: E402
from foresight.core.sim.simulator import Simulator  # noqa: E402
from foresight.core.sim.trace import MAX_TRACE_BYTES, trace_bytes  # noqa: E402

REFERENCE_MATRIX = "reference/robot_sf/configs/scenarios/classic_interactions.yaml"


def open_horizon(n: int, steps: int) -> int:
    """The longest episode up to ``steps`` whose trace with ``n`` pedestrians the trace limit accepts."""
    per_row = trace_bytes(1, n) - trace_bytes(0, n)
    return max(1, min(steps, (MAX_TRACE_BYTES - trace_bytes(0, n)) // per_row))


def open_scenario(n: int, horizon: int) -> ResolvedScenario:
    """A square obstacle-free map at 0.1 peds/m^2 (side >= 20 m), one crowded zone over it, a robot route across;
    episodes of ``horizon`` steps."""
    side = max(20.0, math.sqrt(n / 0.1))
    m = MapDef(
        name=f"open_{n}",
        width=side,
        height=side,
        robot_spawn_zones=(Zone.from_rect(1, 1, 2, 2),),
        robot_goal_zones=(Zone.from_rect(side - 3, side - 3, 2, 2),),
        robot_routes=(Route(spawn_id=0, goal_id=0, waypoints=((2, 2), (side - 2, side - 2))),),
        ped_crowded_zones=(Zone.from_rect(0.5, 0.5, side - 1, side - 1),),
    )
    cfg = SimulationConfig(population_size=n, max_episode_steps=horizon, zone_sampling="full")
    return ResolvedScenario(scenario=Scenario(name=m.name, map_id=m.name, simulation_config=cfg), map=m)


def time_steps(scenario: ResolvedScenario, seed: int, steps: int) -> tuple[float, float]:
    """Wall and CPU (this process) seconds per step over ``steps`` timed steps.

    CPU time excludes the time the process waits for a core, so it stays meaningful on a machine
    shared with other jobs, where wall time can be several times higher.
    """
    sim, planner = Simulator(), GoalSeeking()
    obs = sim.reset(scenario, seed)
    planner.reset(EpisodeInfo(scenario=scenario, seed=seed, dt=sim.dt, robot_radius=1.0, ped_radius=0.4))
    wall = cpu = 0.0
    for _ in range(steps):
        cmd = planner.plan(obs)
        t0, c0 = time.perf_counter(), time.thread_time()
        obs, ev = sim.step(cmd)
        cpu += time.thread_time() - c0
        wall += time.perf_counter() - t0
        if ev.done:
            obs = sim.reset(scenario, seed)
    return wall / steps, cpu / steps


def measure(case: str, scenario: ResolvedScenario, seed: int, steps: int, repeats: int) -> dict:
    n = Simulator().reset(scenario, seed).ped_ids.shape[0]
    runs = [time_steps(scenario, seed, steps) for _ in range(repeats)]
    per = statistics.median(r[0] for r in runs)
    cpu = statistics.median(r[1] for r in runs)
    return {
        "case": case,
        "pedestrians": int(n),
        "ms_per_step": round(per * 1e3, 4),
        "steps_per_s": round(1.0 / per, 1),
        "cpu_ms_per_step": round(cpu * 1e3, 4),
        "cpu_steps_per_s": round(1.0 / cpu, 1) if cpu > 0 else None,
    }


def cold_start(shared: Path) -> float:
    """Seconds from a fresh interpreter to the first simulated step of the first reference scenario."""
    code = (
        "from foresight.core.scenarios.loader import load_matrix\n"
        "from foresight.core.sim.simulator import Simulator\n"
        f"m = load_matrix({str(shared / REFERENCE_MATRIX)!r})\ns = m.scenarios[0]\n"
        "sim = Simulator(); sim.reset(s, s.scenario.seeds[0]); sim.step((0.5, 0.0))\n"
    )
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], cwd=REPO, check=True)
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--sizes", type=int, nargs="*", default=[10, 50, 200, 1000])
    ap.add_argument("--no-reference", action="store_true")
    args = ap.parse_args(argv)
    shared = Path(os.environ.get("FORESIGHT_SHARED", REPO.parent / "shared"))
    entries = []
    for n in args.sizes:
        steps = args.steps if n <= 200 else max(50, args.steps // 4)
        entries.append(measure(f"open_{n}", open_scenario(n, open_horizon(n, steps)), 0, steps, args.repeats))
    cold = None
    if not args.no_reference and (shared / REFERENCE_MATRIX).is_file():
        from foresight.core.scenarios.loader import load_matrix

        for s in load_matrix(shared / REFERENCE_MATRIX).scenarios:
            entries.append(measure(s.name, s, s.scenario.seeds[0], args.steps, args.repeats))
        cold = round(cold_start(shared), 3)
    classic = [e for e in entries if not e["case"].startswith("open_")]
    summary = {}
    for key in ("ms_per_step", "cpu_ms_per_step"):
        vals = [e[key] for e in classic]
        summary[f"classic_median_{key}"] = round(statistics.median(vals), 4) if vals else None
        summary[f"classic_max_{key}"] = max(vals) if vals else None
    result = {
        "entries": entries,
        "cold_start_s": cold,
        **summary,
        "cpu_count": os.cpu_count(),
        "load_avg": os.getloadavg()[0],
    }
    if args.json:
        print(json.dumps(result))
    else:
        for e in entries:
            print(
                f"{e['case']:45s} {e['pedestrians']:5d} peds {e['ms_per_step']:8.3f} ms/step {e['steps_per_s']:9.1f} steps/s"
                f"  (cpu {e['cpu_ms_per_step']:.3f} ms/step)"
            )
        print(f"cold start to first step: {cold} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
