"""Prediction commands: ``predict-eval``, ``dataset import-ethucy``, ``collect``, ``mix`` and ``train``.

Each builds its job kind's spec (``cli.stage``) and submits it to the server, following the job (the
default), or runs it in-process with ``--local``. On the server datasets and models are ids; with
``--local`` they may be local files (.npz, checkpoints).
Exit codes: 0 ok, 2 training gates failed (summary written), 1 error (or a failed job).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from foresight import local
from foresight.cli import datasets, stage
from foresight.core.errors import ConfigError
from foresight.local import build_config, finish_local, local_context, local_workdir, matrix_ref
from foresight.paths import user_file


def register(sub: argparse._SubParsersAction) -> None:
    pe = sub.add_parser("predict-eval", help="ADE/FDE of a predictor on ETH/UCY folds or a dataset")
    who = pe.add_mutually_exclusive_group(required=True)
    who.add_argument(
        "--model",
        help="model id, cv, static or a predictor plug-in name (--local: also a checkpoint path, module:attr)",
    )
    who.add_argument(
        "--train", action="store_true", help="train the default model (or --config) per fold first"
    )
    pe.add_argument("--config", help="training config YAML (its 'train' mapping, or the whole file)")
    data = pe.add_mutually_exclusive_group(required=True)
    data.add_argument(
        "--ethucy",
        metavar="ROOT",
        help="ETH/UCY data root name (GET /v1/data-roots, e.g. ethucy); "
        "--local also takes a folder with <fold>/train|val|test",
    )
    data.add_argument(
        "--dataset", help="dataset id (--local: a .npz file), scored on its test split, else val"
    )
    data.add_argument(
        "--scenes",
        help="--local: your recordings (a file or a folder, one scene per file): leave-one-scene-out",
    )
    datasets.add_scene_args(pe, required=False)
    pe.add_argument("--fold", help="one fold (eth|hotel|univ|zara1|zara2); default all")
    pe.add_argument(
        "--split", help="dataset split to score: test (default; val when there is no test), val, all"
    )
    pe.add_argument("--best-of", type=int, help="K of minADE_K / minFDE_K (default 20)")
    _outputs(pe)
    pe.set_defaults(func=predict_eval_cmd)

    ds = sub.add_parser("dataset", help="prediction datasets")
    dsub = ds.add_subparsers(dest="dataset_command", required=True)
    im = dsub.add_parser(
        "import-ethucy",
        help="import one ETH/UCY fold as a dataset (server: a dataset record; --local: .npz + .json files)",
    )
    im.add_argument("--root", help="data root name on the server (GET /v1/data-roots; default ethucy)")
    im.add_argument("--ethucy", help="--local: ETH/UCY root folder")
    im.add_argument("--fold", required=True, help="ETH/UCY fold: eth, hotel, univ, zara1 or zara2")
    im.add_argument("--max-agents", type=int, default=12, help="pedestrians kept per sample (default 12)")
    im.add_argument("--output", help="--local: output .npz path")
    stage.add_mode_args(im)
    im.set_defaults(func=import_cmd)
    datasets.register(dsub)

    co = sub.add_parser("collect", help="roll out episodes and write a prediction dataset")
    co.add_argument(
        "--config", help="YAML whose 'collect' mapping holds CollectConfig fields (flags override)"
    )
    co.add_argument("--section", default="collect", help="mapping of --config to read (e.g. hardcase)")
    co.add_argument("--matrix", default=None, help="scenario matrix YAML (default: builtin classic matrix)")
    co.add_argument("--hard-seeds", help="TRAINING seed manifest YAML (hard-case collection)")
    co.add_argument("--bundle", help="server: config bundle id; --matrix/--hard-seeds are names inside it")
    co.add_argument("--scenarios", help="comma-separated scenario names (base collection)")
    co.add_argument("--seeds-per-scenario", type=int, help="episodes per scenario (default: the config's)")
    co.add_argument("--base-seed", type=int, help="first episode seed (default: the config's)")
    co.add_argument("--policy", choices=["goal", "goal_noisy"], help="how the robot drives while recording")
    co.add_argument("--max-steps", type=int, help="horizon override (default: each scenario's)")
    co.add_argument("--max-agents", type=int, help="pedestrians kept per sample")
    co.add_argument("--executor", choices=["local", "ray"], help=stage.EXECUTOR_HELP)
    co.add_argument(
        "--override",
        action="append",
        metavar="KEY=VALUE",
        help="collect under other conditions, as foresight evaluate --override (repeatable)",
    )
    _outputs(co)
    co.set_defaults(func=collect_cmd)

    mx = sub.add_parser("mix", help="base + hard-case dataset, hard-case training rows oversampled")
    mx.add_argument("--base", required=True, help="dataset id (--local: a .npz file)")
    mx.add_argument("--hardcase", required=True, help="dataset id (--local: a .npz file)")
    mx.add_argument(
        "--repeat", type=int, default=3, help="times the hard-case samples are repeated (default 3)"
    )
    _outputs(mx)
    mx.set_defaults(func=mix_cmd)

    tr = sub.add_parser("train", help="train the trajectory predictor on a dataset")
    tr.add_argument("--dataset", help="dataset id (--local: a .npz file); overrides the config's")
    tr.add_argument("--config", help="training config YAML (its 'train' mapping, or the whole file)")
    tr.add_argument("--epochs", type=int, help="training epochs; overrides the config's")
    tr.add_argument("--threads", type=int, help="torch CPU threads (default: torch's)")
    tr.add_argument(
        "--device",
        choices=["auto", "cpu", "cuda"],
        help="torch device where training runs (auto: cuda "
        "when it sees a GPU, else cpu); overrides the config's",
    )
    tr.add_argument(
        "--executor",
        choices=["local", "ray"],
        help="ray: train as a Ray task (on a GPU node when the "
        "cluster has one) and run the closed-loop proxy's episodes as Ray tasks; default local",
    )
    _outputs(tr)
    tr.set_defaults(func=train_cmd)


def _outputs(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", help="--local: work folder (default: a new folder under <data dir>/runs)")
    stage.add_mode_args(p)


def _ctx(args: argparse.Namespace, bundles: dict[str, Path] | None = None):
    return local_context(local_workdir(args.out, args.command), bundles or {}, quiet=args.json)


def _section(path: str | None, key: str) -> dict:
    """The ``key`` mapping of a YAML file (or the whole file when it has no such key)."""
    if path is None:
        return {}
    from foresight.core.scenarios.loader import read_yaml

    data = read_yaml(user_file(path, "--config"))
    if not isinstance(data, dict) or not isinstance(data.get(key, data), dict):
        raise ConfigError(f"expected a mapping (optionally under {key!r})", source=path, item=key)
    return dict(data.get(key, data))


def _train_values(path: str | None) -> dict:
    return _section(path, "train")


def _eval_values(path: str | None) -> dict:
    """The predict-eval stage's own keys in a training config file, beside its ``train`` mapping (``FILE_KEYS``)."""
    if path is None:
        return {}
    from foresight.core.scenarios.loader import read_yaml
    from foresight.core.training.predict_eval import FILE_KEYS

    data = read_yaml(user_file(path, "--config"))
    return {k: data[k] for k in FILE_KEYS if isinstance(data, dict) and "train" in data and k in data}


def predict_eval_cmd(args: argparse.Namespace) -> int:
    from foresight.core.training.predict_eval import PredictEvalResult

    train, own = None, {}
    if args.train:
        train = {k: v for k, v in _train_values(args.config).items() if k != "dataset"}
        own = _eval_values(args.config)
    values = {
        "model": args.model,
        "train": train,
        "ethucy": args.ethucy,
        "dataset": args.dataset,
        "folds": [args.fold] if args.fold else None,
        "split": args.split,
        **({"best_of": args.best_of} if args.best_of else {}),
        **({"scenes": datasets.scene_values(args, args.scenes)} if args.scenes else {}),
        **own,
    }
    if not args.local:
        stage.local_only(args, out="--out", scenes="--scenes")
        if args.ethucy is not None and Path(args.ethucy).expanduser().is_dir():
            raise ConfigError(
                f"{args.ethucy!r} is a local folder; the server reads named data roots: pass "
                "--ethucy NAME (GET /v1/data-roots), or run in-process with --local",
                source="command line",
                item="--ethucy",
            )
        values.update(
            model=stage.model_id(args.model, "--model"), dataset=stage.dataset_id(args.dataset, "--dataset")
        )
        return stage.submit(
            args, local.spec("predict_eval", values), text=_score_table, result_model=PredictEvalResult
        )
    from foresight.core.training.predict_eval import run_predict_eval

    spec, ctx = local.spec("predict_eval", values), _ctx(args)
    result, started = stage.run_local(
        args, spec, lambda: run_predict_eval(local.config_of(spec), ctx), ctx.workdir
    )
    stage.emit_local(
        args, spec, result, lambda r: _score_table(r, None), started=started, workdir=ctx.workdir
    )
    return 0


def _score_table(result, where: str | None) -> str:  # noqa: ANN001
    """Best-of-1 ADE/FDE and constant velocity's per fold; minADE_K/minFDE_K, NLL and the 1/2-sigma shares when
    the predictor gave more than one mode or a spread (each column labelled with its K)."""
    a, c = result.average, result.cv_average
    k = a.best_of or 1
    extra = [
        (f"minADE{k}", "min_ade", ".3f"),
        (f"minFDE{k}", "min_fde", ".3f"),
        ("NLL", "nll", ".2f"),
        ("<1sig", "within_1sigma", ".2f"),
        ("<2sig", "within_2sigma", ".2f"),
        ("ADE m0", "first_ade", ".3f"),
        ("FDE m0", "first_fde", ".3f"),
    ]
    extra = [
        e for e in extra if getattr(a, e[1]) is not None and (k > 1 or e[1] not in ("min_ade", "min_fde"))
    ]
    w = max([10, *(len(n) + 1 for n in result.folds)])  # scene names of imported data can be long
    head = f"{'fold':<{w}}{'samples':>9}{'ADE':>8}{'FDE':>8}{'CV ADE':>9}{'CV FDE':>9}"
    lines = [head + "".join(f"{h:>9}" for h, _, _ in extra)]

    def row(name, f, n):  # noqa: ANN001
        cells = "".join(f"{getattr(f, key):>9{fmt}}" for _, key, fmt in extra)
        return f"{name:<{w}}{n:>9}{f.ade:>8.3f}{f.fde:>8.3f}{c_ade(f):>9.3f}{c_fde(f):>9.3f}{cells}"

    def c_ade(f):  # noqa: ANN001
        return getattr(f, "cv_ade", c.ade)

    def c_fde(f):  # noqa: ANN001
        return getattr(f, "cv_fde", c.fde)

    for name, f in result.folds.items():
        lines.append(row(name, f, f.samples))
    lines.append(row("average", a, ""))
    asked = getattr(a, "best_of_asked", None) or k
    if k > 1:
        fewer = (
            f" (K = {asked} asked; the model gives {k} modes: the minimum over all of them)"
            if k < asked
            else ""
        )
        lines.append(f"ADE/FDE: most likely mode (best-of-1); minADE{k}/minFDE{k}: best of {k} modes{fewer}")
    if a.first_ade is not None:
        lines.append("ADE/FDE m0: the first mode (a network with modes: its deterministic trajectory)")
    return "\n".join(lines + ([where] if where else []))


def import_cmd(args: argparse.Namespace) -> int:
    if not args.local:
        from foresight.core.predict.ethucy import ImportDatasetConfig

        stage.local_only(args, output="--output")
        if args.ethucy is not None:
            raise ConfigError(
                "--ethucy names a local folder; the server reads named data roots: pass --root NAME "
                "(GET /v1/data-roots), or run in-process with --local",
                source="command line",
                item="--ethucy",
            )
        # validated against the core config here; the server checks the root name against its own roots
        config = build_config(
            ImportDatasetConfig, {"root": args.root, "fold": args.fold, "max_agents": args.max_agents}
        )
        return stage.submit(
            args,
            config,
            kind="import_dataset",
            text=lambda r, ref: (
                f"dataset {ref.id} (fold {r['fold']} of data root {r['root']}): {r['summary']['samples']} samples "
                f"{r['summary']['samples_per_split']}\n{ref}"
            ),
        )
    from foresight.core.predict.ethucy import ImportEthucyConfig, run_import_ethucy

    if args.output is None:
        raise ConfigError("--local imports need --output FILE.npz", source="command line", item="--output")
    if (args.ethucy is None) == (args.root is None):
        raise ConfigError(
            "give --ethucy FOLDER (or --root NAME of FORESIGHT_DATA_ROOTS)",
            source="command line",
            item="--ethucy",
        )
    if args.ethucy is None:
        from foresight.store.settings import Settings

        folder = Settings().data_root(args.root)
    else:
        folder = Path(args.ethucy).resolve()
    out = Path(args.output).resolve()
    config = build_config(
        ImportEthucyConfig,
        {"root": str(folder), "fold": args.fold, "max_agents": args.max_agents, "output": out.name},
    )
    from foresight.core.jobs.kinds import imported_dataset

    origin = {"source": "ethucy", "root": args.root or str(folder), "fold": args.fold}
    spec = {"kind": "import_dataset", **origin, "max_agents": args.max_agents}
    record, started = stage.run_local(
        args, spec, lambda: run_import_ethucy(config, local_context(out.parent, {}, quiet=True))
    )
    stage.emit_local(
        args,
        spec,
        imported_dataset(record, origin),
        started=started,
        files=[out],
        text=lambda r: (
            f"{args.output}: {r['summary']['samples']} samples {r['summary']['samples_per_split']}"
        ),
    )
    return 0


def collect_cmd(args: argparse.Namespace) -> int:
    from foresight.core.training.collect import CollectResult
    from foresight.local import overrides

    flags = {
        "scenarios": args.scenarios.split(",") if args.scenarios else None,
        "seeds_per_scenario": args.seeds_per_scenario,
        "base_seed": args.base_seed,
        "policy": args.policy,
        "max_steps": args.max_steps,
        "max_agents": args.max_agents,
        "scenario_overrides": overrides(args.override) or None,
        "executor": args.executor,
    }
    values = {**_section(args.config, args.section), **{k: v for k, v in flags.items() if v is not None}}
    if not args.local:
        stage.local_only(args, out="--out")
        if args.matrix or args.hard_seeds or args.bundle:
            bundle, names = stage.bundle_names(
                args.bundle, {"--matrix": args.matrix, "--hard-seeds": args.hard_seeds}
            )
            values.update(bundle=bundle, matrix=names["--matrix"], hard_seeds=names["--hard-seeds"])
        return stage.submit(
            args,
            local.spec("collect", values),
            result_model=CollectResult,
            text=lambda r, ref: (
                f"dataset {ref.id}: {r.summary.samples} samples, outcomes {r.outcomes}\n{ref}"
            ),
        )
    if args.bundle:
        raise ConfigError(
            "--bundle names a server bundle; --local runs take --matrix/--hard-seeds files",
            source="command line",
            item="--bundle",
        )
    from foresight.core.training.collect import run_collect

    if args.matrix or args.hard_seeds:  # local files; a --config's paths are relative to the builtin configs/
        from foresight.local import bundle_of

        bundle, rel, bundles = bundle_of(args.matrix or str(_builtin_matrix()), args.hard_seeds)
        values.update(bundle=bundle, matrix=rel[0], hard_seeds=rel[1])
    else:
        bundles = matrix_ref(str(_builtin_matrix()))[2]
    spec, ctx = local.spec("collect", values), _ctx(args, bundles)
    result, started = stage.run_local(
        args, spec, lambda: run_collect(local.config_of(spec), ctx), ctx.workdir
    )
    stage.emit_local(
        args,
        spec,
        result,
        started=started,
        workdir=ctx.workdir,
        text=lambda r: f"{ctx.workdir / r.dataset}: {r.summary.samples} samples, outcomes {r.outcomes}",
    )
    return 0


def _builtin_matrix() -> Path:
    from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT

    return BUILTIN_CONFIG_ROOT / "scenarios" / "classic_interactions.yaml"


def mix_cmd(args: argparse.Namespace) -> int:
    from foresight.core.training.collect import CollectResult

    values = {"base": args.base, "hardcase": args.hardcase, "hardcase_repeat": args.repeat}
    if not args.local:
        stage.local_only(args, out="--out")
        values.update(
            base=stage.dataset_id(args.base, "--base"), hardcase=stage.dataset_id(args.hardcase, "--hardcase")
        )
        return stage.submit(
            args,
            local.spec("mix", values),
            result_model=CollectResult,
            text=lambda r, ref: f"dataset {ref.id}: {r.summary.samples} samples\n{ref}",
        )
    from foresight.core.training.collect import run_mix

    spec, ctx = local.spec("mix", values), _ctx(args)
    result, started = stage.run_local(args, spec, lambda: run_mix(local.config_of(spec), ctx), ctx.workdir)
    stage.emit_local(
        args,
        spec,
        result,
        lambda r: f"{r.dataset}: {r.summary.samples} samples",
        started=started,
        workdir=ctx.workdir,
    )
    return 0


def train_cmd(args: argparse.Namespace) -> int:
    from foresight.core.training.config import TrainResult

    overrides = {
        "dataset": args.dataset,
        "epochs": args.epochs,
        "threads": args.threads,
        "device": args.device,
    }
    values = {**_train_values(args.config), **{k: v for k, v in overrides.items() if v is not None}}
    if values.get("dataset") is None:
        raise ConfigError("no dataset: give --dataset or a config with train.dataset", source=args.config)
    if args.executor:
        values["executor"] = args.executor
        if isinstance(values.get("proxy"), dict):
            values["proxy"] = {**values["proxy"], "executor": args.executor}

    def text(r: TrainResult, where: str, checkpoint: str | None = None) -> str:
        on = f", trained on {r.device}" if r.device else ""
        return (
            f"{checkpoint or r.checkpoint}: epoch {r.best_epoch} val ADE {r.val_ade:.3f} FDE {r.val_fde:.3f} "
            f"(CV {r.cv_val_ade:.3f}/{r.cv_val_fde:.3f}), gates {'passed' if r.gates_passed else 'FAILED'}{on}{where}"
        )

    def exit_code(r: TrainResult) -> int:
        return 0 if r.gates_passed else 2

    if not args.local:
        stage.local_only(args, out="--out")
        values["dataset"] = stage.dataset_id(str(values["dataset"]), "--dataset")
        return stage.submit(
            args,
            local.spec("train", values),
            result_model=TrainResult,
            exit_code=exit_code,
            text=lambda r, ref: text(
                r,
                f"\n{ref}\nregister it: foresight models register MODEL_ID "
                f"--job {ref.id} --artifact {Path(r.checkpoint).name}",
                Path(r.checkpoint).name,
            ),
        )
    from foresight.core.jobs.kinds import run_train  # executor local: in this process; ray: a Ray task

    spec, ctx = local.spec("train", values), _ctx(args)
    result, started = stage.run_local(args, spec, lambda: run_train(local.config_of(spec), ctx), ctx.workdir)
    pages = finish_local("train", result, ctx.workdir)  # as a worker does: the report page, the MLflow copy
    stage.emit_local(
        args,
        spec,
        result,
        started=started,
        workdir=ctx.workdir,
        text=lambda r: text(r, "".join(f"\nreport: {p.resolve()}" for p in pages if p.name == "report.html")),
    )
    return exit_code(result)
