"""`foresight scenarios list`, `check` and `reachable` (and `witness`, from ``cli.witness``), `foresight sim run` and `foresight sim demo`."""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path
from typing import TYPE_CHECKING

from foresight import local
from foresight.cli import stage, witness
from foresight.cli.common import emit, episode_options, matrix_options
from foresight.core.errors import ConfigError
from foresight.core.jobs.simulate import SimulateConfig, SimulateResult, run_simulate
from foresight.local import build_config, local_context, matrix_ref, progress_bar
from foresight.paths import user_file

if TYPE_CHECKING:
    from foresight.core.scenarios.model import ResolvedScenario
    from foresight.core.sim.feasibility import Reachability


def register(sub: argparse._SubParsersAction) -> None:
    scen = sub.add_parser("scenarios", help="inspect scenario matrices").add_subparsers(
        dest="action", required=True
    )
    ls = scen.add_parser("ls", aliases=["list"], help="list the scenarios of a matrix")
    ls.add_argument("--matrix", required=True, help="scenario matrix YAML")
    ls.add_argument("--json", action="store_true")
    ls.set_defaults(func=scenarios_list)
    chk = scen.add_parser(
        "check",
        help="episodes lost before a planner can act: a standing robot walked into "
        "within the first seconds (exit 1 if any)",
    )
    matrix_options(chk)
    chk.add_argument(
        "--seeds-per-scenario", type=int, help="the first N of each scenario's seeds (default: all)"
    )
    chk.add_argument("--seconds", type=float, default=1.5, help="how long the robot stands [s] (default 1.5)")
    chk.add_argument("--json", action="store_true")
    chk.set_defaults(func=scenarios_check)
    rch = scen.add_parser(
        "reachable",
        help="episodes no robot could solve: space-time reachability of the goal "
        "against the crowd as it walks (exact where nobody reacts to the robot)",
    )
    episode_options(rch, "its success on the reachable episodes")
    rch.add_argument(
        "--pictures",
        metavar="DIR",
        help="also draw each verdict: DIR/reach_<scenario>_<seed>.png (when "
        "each place became reachable, the crowd, start and goal)",
    )
    rch.add_argument("--json", action="store_true")
    rch.set_defaults(func=scenarios_reachable)
    witness.add_parser(scen)

    sim = sub.add_parser("sim", help="run the simulator").add_subparsers(dest="action", required=True)
    run = sim.add_parser("run", help="one episode with a planner (default: the goal-seeking robot)")
    run.add_argument(
        "--matrix",
        required=True,
        help="scenario matrix YAML (server: a name in --bundle, or a file in the project's configs/)",
    )
    run.add_argument("--bundle", help="server: config bundle id; --matrix is a name inside it")
    run.add_argument(
        "--scenario", required=True, help="scenario name in the matrix (`foresight scenarios ls`)"
    )
    run.add_argument(
        "--seed", type=int, required=True, help="episode seed (the crowd's and the robot's randomness)"
    )
    run.add_argument(
        "--render",
        metavar="FILE",
        help="write the episode here, as its suffix says: .png/.svg a picture, .gif/.mp4 a replay "
        "(MP4: the video extra) (server: downloaded from the job)",
    )
    run.add_argument(
        "--planner", default="goal", help="planner name (as for evaluate; default goal) or a planner YAML"
    )
    run.add_argument("--planner-config", help="the planner's config as inline JSON/YAML")
    run.add_argument(
        "--model",
        help="predictive planner: model id, cv or static (--local: also a checkpoint path; default: "
        "the default predictor)",
    )
    stage.add_mode_args(run)
    run.set_defaults(func=sim_run)

    demo = sim.add_parser("demo", help="simulator demo: a few classic episodes, rendered and summarised")
    demo.add_argument("--out", default="out/demo", help="folder for renders and the summary")
    demo.add_argument("--json", action="store_true")
    demo.set_defaults(func=demo_run)


def scenarios_list(args: argparse.Namespace) -> int:
    from foresight.core.scenarios.loader import load_matrix
    from foresight.core.sim.population import pedestrian_count

    matrix = load_matrix(user_file(args.matrix, "--matrix"))
    rows = [
        {
            "name": s.name,
            "map": s.map.name,
            "archetype": s.scenario.archetype,
            "density": s.scenario.simulation_config.ped_density,
            "pedestrians": pedestrian_count(s),
            "horizon": s.scenario.simulation_config.max_episode_steps,
            "seeds": list(s.scenario.seeds),
        }
        for s in matrix.scenarios
    ]
    emit(rows, args.json, _table)
    return 0


def scenarios_check(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from foresight.core.scenarios.loader import load_matrix
    from foresight.core.sim.spawn_check import early_contacts
    from foresight.local import overrides

    if not 0 < args.seconds <= 60:
        raise ConfigError(
            f"expected 0 < seconds <= 60, got {args.seconds}", source="command line", item="--seconds"
        )
    matrix = load_matrix(user_file(args.matrix, "--matrix"), overrides=overrides(args.override))
    seeds = {s.name: list(s.scenario.seeds)[: args.seeds_per_scenario] for s in matrix.scenarios}
    lost = early_contacts(matrix.scenarios, args.seconds, seeds)
    report = {
        "matrix": args.matrix,
        "seconds": args.seconds,
        "episodes": sum(map(len, seeds.values())),
        "lost": [asdict(c) for c in lost],
    }
    emit(
        report,
        args.json,
        lambda r: "\n".join(
            [
                f"{r['episodes']} episodes, a robot standing still for {r['seconds']:g} s: "
                + (
                    f"{len(r['lost'])} walked into (lost before a planner can act)"
                    if r["lost"]
                    else "none walked into"
                )
            ]
            + [f"  {c['scenario']} seed {c['seed']}: contact at {c['time_s']:g} s" for c in r["lost"]]
        ),
    )
    return 1 if lost else 0


def scenarios_reachable(args: argparse.Namespace) -> int:
    from foresight.core.evaluation.runner import expand_seeds, read_outcomes
    from foresight.core.scenarios.loader import load_matrix
    from foresight.core.sim.feasibility import reachability
    from foresight.local import overrides

    matrix = load_matrix(user_file(args.matrix, "--matrix"), overrides=overrides(args.override))
    chosen = (
        [matrix.get(n.strip()) for n in args.scenarios.split(",")]
        if args.scenarios
        else list(matrix.scenarios)
    )
    if args.seeds_per_scenario is not None and args.seeds_per_scenario < 1:
        raise ConfigError(
            f"expected a positive count, got {args.seeds_per_scenario}",
            source="command line",
            item="--seeds-per-scenario",
        )
    outcomes = read_outcomes(args.episodes) if args.episodes else None
    episodes = [(s, seed) for s in chosen for seed in expand_seeds(s.scenario.seeds, args.seeds_per_scenario)]
    if outcomes is not None:  # before the work: the evaluation must hold every episode asked about
        missing = [f"{s.name} {seed}" for s, seed in episodes if (s.name, seed) not in outcomes]
        if missing:
            raise ConfigError(
                f"no episode for {missing[0]} (and {len(missing) - 1} more)", source=args.episodes
            )
    pictures = Path(args.pictures) if args.pictures else None
    if pictures is not None:
        if pictures.exists() and not pictures.is_dir():
            raise ConfigError(
                "expected a folder for the pictures, found a file", source=pictures, item="--pictures"
            )
        pictures.mkdir(parents=True, exist_ok=True)
    rows = []
    with progress_bar(quiet=args.json) as bar:  # about 1 s an episode (a picture about half as much again)
        task = bar.add_task("reachable", total=len(episodes), message="")
        for s, seed in episodes:
            r = reachability(s, int(seed), keep_map=pictures is not None)
            rows.append(
                {
                    "scenario": r.scenario,
                    "seed": r.seed,
                    "reachable": r.reachable,
                    "first_step": r.first_step,
                    "peds_react": r.peds_react,
                }
            )
            if pictures is not None:
                rows[-1]["picture"] = str(_reach_picture(r, s, pictures))
            bar.update(task, advance=1, message=f"{s.name} {seed}")
    report: dict = {
        "matrix": args.matrix,
        "episodes": len(rows),
        "reachable": sum(r["reachable"] for r in rows),
        "unreachable": [r for r in rows if not r["reachable"]],
        "approximate": any(r["peds_react"] for r in rows),
    }
    report["verdicts"] = (
        rows  # every episode: reachable, first_step (when the relaxed robot could be at the goal)
    )
    if pictures is not None:
        report["pictures"] = [r["picture"] for r in rows]
    if outcomes is not None:
        ok = [r for r in rows if r["reachable"]]
        wins = sum(outcomes[r["scenario"], r["seed"]] == "success" for r in ok)
        report["success_on_reachable"] = {
            "successes": wins,
            "episodes": len(ok),
            "rate": wins / len(ok) if ok else None,
        }
    emit(report, args.json, _reachable_text)
    return 0


def _reach_picture(r: Reachability, scenario: ResolvedScenario, folder: Path) -> Path:
    """Draw one verdict (``core.render.reachability``) into ``folder``; returns the file."""
    from foresight.core.render.reachability import render_reachability

    when = (
        f"goal reachable at {r.first_step * r.where.dt:g} s"
        if r.reachable
        else (f"goal unreachable within {r.horizon * r.where.dt:g} s")
    )
    title = f"{r.scenario} seed {r.seed}: {when}" + (" (approximate)" if r.peds_react else "")
    return render_reachability(
        r.where,
        scenario.map,
        folder / f"reach_{r.scenario}_{r.seed}.png",
        title=title,
        ped_radius=scenario.scenario.simulation_config.ped_radius,
    )


def _reachable_text(r: dict) -> str:
    lines = [
        f"{r['episodes']} episodes: {r['reachable']} reachable, {len(r['unreachable'])} no robot could solve"
        + (" (approximate: pedestrians react to the robot)" if r["approximate"] else "")
    ]
    lines += [f"  {u['scenario']} seed {u['seed']}: goal unreachable" for u in r["unreachable"]]
    if "success_on_reachable" in r:
        s = r["success_on_reachable"]
        lines.append(f"success on the reachable episodes: {s['successes']}/{s['episodes']}")
    if "pictures" in r:
        lines.append(
            f"{len(r['pictures'])} pictures in {Path(r['pictures'][0]).parent}"
            if r["pictures"]
            else "no pictures"
        )
    return "\n".join(lines)


def _table(rows: list[dict]) -> str:
    head = f"{'name':<44} {'map':<30} {'density':>7} {'peds':>5} {'horizon':>7}  seeds"
    lines = [head, "-" * len(head)]
    for r in rows:
        seeds = ",".join(map(str, r["seeds"][:6])) + ("…" if len(r["seeds"]) > 6 else "")
        lines.append(
            f"{r['name']:<44} {r['map']:<30} {r['density']:>7.3f} {r['pedestrians']:>5} {r['horizon']:>7}  {seeds}"
        )
    lines.append(f"{len(rows)} scenarios")
    return "\n".join(lines)


RENDER_SUFFIXES = ("png", "svg", "gif", "mp4")


def render_format(path: str) -> str:
    """The picture kind a ``--render`` file's suffix asks for; an unknown suffix is refused before anything runs."""
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in RENDER_SUFFIXES:
        raise ConfigError(
            f"{path!r}: expected a file ending in {', '.join('.' + s for s in RENDER_SUFFIXES)}",
            source="command line",
            item="--render",
        )
    return suffix


def sim_run(args: argparse.Namespace) -> int:
    from foresight.local import ModelArgs, planner_spec

    values = {"scenarios": [args.scenario], "seeds": [args.seed], "render": bool(args.render)}
    if args.render:
        values["render_format"] = render_format(args.render)
    models = ModelArgs()
    if not args.local:
        client = stage.Client.from_args(args)
        planner = planner_spec(
            args.planner, None, models, default=False, config=args.planner_config, local=False
        )
        if args.model is not None:
            planner["model"] = stage.model_id(args.model, "--model")
        elif planner.get("name") == "predictive" and "model" not in planner:
            planner["model"] = stage.server_default_model(client)
        bundle, names = stage.bundle_names(args.bundle, {"--matrix": args.matrix})
        spec = local.spec(
            "simulate", {**values, "bundle": bundle, "matrix": names["--matrix"], "planner": planner}
        )
        return stage.submit(
            args,
            spec,
            client=client,
            result_model=SimulateResult,
            after=_download_render(args.render),
            text=lambda r, ref: f"{_episode_line(r.episodes[0])}\n{ref}",
        )
    if args.bundle:
        raise ConfigError(
            "--bundle names a server bundle; --local runs take a --matrix file",
            source="command line",
            item="--bundle",
        )
    bundle, rel, roots = matrix_ref(args.matrix)
    planner = planner_spec(args.planner, args.model, models, config=args.planner_config)
    spec = local.spec("simulate", {**values, "bundle": bundle, "matrix": rel, "planner": planner})
    ctx = local_context(None, roots, quiet=True)
    ctx.resolve_model = models.resolve
    result, started = stage.run_local(args, spec, lambda: run_simulate(local.config_of(spec), ctx))
    episode = result.episodes[0]
    files = []
    if args.render and episode.render:
        shutil.copyfile(ctx.workdir / episode.render, args.render)
        files.append(Path(args.render))
        episode = episode.model_copy(update={"render": str(Path(args.render).resolve())})
        result = result.model_copy(update={"episodes": [episode, *result.episodes[1:]]})
    stage.emit_local(args, spec, result, lambda r: _episode_line(r.episodes[0]), started=started, files=files)
    return 0


def _download_render(target: str | None):  # noqa: ANN202
    """After a server run: fetch the episode's render artifact to ``target`` (the result then names the file)."""

    def after(result: SimulateResult, ref: stage.JobRef, client: stage.Client) -> SimulateResult:
        from foresight.cli.client import ApiError

        episode = result.episodes[0]
        if not target or not episode.render:
            return result
        try:
            data = client.download(f"/v1/jobs/{ref.id}/artifacts/{episode.render}")
        except ApiError as exc:
            raise ConfigError(
                f"cannot download render {episode.render!r} of job {ref.id}: HTTP {exc.status}"
            ) from None
        Path(target).write_bytes(data)
        rendered = episode.model_copy(update={"render": str(Path(target).resolve())})
        return result.model_copy(update={"episodes": [rendered, *result.episodes[1:]]})

    return after


def _episode_line(e) -> str:
    dist = f"{e.min_distance:.2f} m" if e.min_distance is not None else "n/a (no pedestrians)"
    line = f"{e.scenario} seed {e.seed}: {e.outcome} after {e.steps} steps, min distance {dist}, wall {e.wall_s:.2f} s"
    return line + (f"\nrender: {e.render}" if e.render else "")


#: One scenario per classic family keeps the demo short while showing every kind of scene.
DEMO_SCENARIOS = 6


def demo_run(args: argparse.Namespace) -> int:
    from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
    from foresight.core.scenarios.loader import load_matrix

    matrix_path = BUILTIN_CONFIG_ROOT / "scenarios" / "classic_interactions.yaml"
    matrix = load_matrix(matrix_path)
    families: dict[str, str] = {}
    for s in matrix.scenarios:
        families.setdefault(s.scenario.archetype, s.name)
    names = list(families.values())[:DEMO_SCENARIOS]
    bundle, rel, roots = matrix_ref(str(matrix_path))
    config = build_config(SimulateConfig, {"bundle": bundle, "matrix": rel, "scenarios": names})
    out = Path(args.out)
    ctx = local_context(out, roots, quiet=args.json)
    result = run_simulate(config, ctx)
    emit(result, args.json, lambda r: _demo_text(r, out))
    return 0


def _demo_text(result: SimulateResult, out: Path) -> str:
    lines = ["Foresight simulator demo: goal-seeking robot (no avoidance) on our classic matrix", ""]
    lines += [_episode_line(e).split("\n")[0] for e in result.episodes]
    lines += ["", f"outcomes: {json.dumps(result.outcomes)}", f"renders and simulate.json in {out.resolve()}"]
    return "\n".join(lines)
