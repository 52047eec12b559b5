"""``dataset import`` (your own TrajNet++ or text/CSV recordings), ``dataset export`` (TrajNet++ ndjson) and
``dataset ls``; and the scene flags ``predict-eval --scenes`` shares with ``dataset import``."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from foresight.cli.client import add_connection_args
from foresight.core.errors import ConfigError
from foresight.local import build_config


def add_scene_args(p: argparse.ArgumentParser, *, required: bool) -> None:
    """How a recording is read: format, column order, declared frame interval, frame step and units."""
    p.add_argument(
        "--format", choices=["text", "trajnet"], default="text", help="text/CSV or TrajNet++ ndjson"
    )
    p.add_argument(
        "--columns", default="frame,id,x,y", help="text: column order (other names: skipped columns)"
    )
    p.add_argument(
        "--frame-interval", type=float, required=required, help="[s] between consecutive annotations"
    )
    p.add_argument("--frame-step", type=float, help="frame-number units per annotation (default: inferred)")
    p.add_argument("--units", choices=["m", "cm", "mm"], default="m", help="coordinate units")
    p.add_argument("--dt", type=float, help="time base step [s] (default 0.4)")
    p.add_argument("--history", type=int, help="observed steps (default 8)")
    p.add_argument("--horizon", type=int, help="predicted steps (default 12)")


def scene_values(args: argparse.Namespace, path: str) -> dict[str, Any]:
    """ImportScenesConfig fields from the scene flags."""
    from foresight.core.predict.timebase import ETHUCY_TIMEBASE

    tb = ETHUCY_TIMEBASE.to_dict()
    tb.update({k: getattr(args, k) for k in ("dt", "history", "horizon") if getattr(args, k) is not None})
    values: dict[str, Any] = {
        "path": path,
        "format": args.format,
        "columns": args.columns,
        "frame_interval": args.frame_interval,
        "units": args.units,
        "timebase": tb,
    }
    if args.frame_step is not None:
        values["frame_step"] = args.frame_step
    return values


def register(dsub: argparse._SubParsersAction) -> None:
    im = dsub.add_parser(
        "import",
        help="import your own recordings (one file or a folder, one scene per file) as a dataset (--local)",
    )
    im.add_argument("path", help="a TrajNet++ .ndjson or text/CSV file, or a folder of them")
    add_scene_args(im, required=True)
    im.add_argument("--test-scene", help="the held-out scene (file stem); default: every scene is test")
    im.add_argument("--val-scene", help="a validation scene (file stem)")
    im.add_argument("--max-agents", type=int, default=12, help="pedestrians kept per sample (default 12)")
    im.add_argument("--output", required=True, help="output .npz path")
    im.add_argument("--local", action="store_true", help="run in-process (required: files are read locally)")
    im.add_argument("--json", action="store_true")
    im.set_defaults(func=import_cmd)

    ex = dsub.add_parser("export", help="write a dataset (.npz) as TrajNet++ ndjson, one scene per sample")
    ex.add_argument("dataset", help="dataset .npz file")
    ex.add_argument("--output", required=True, help="output .ndjson path")
    ex.add_argument("--split", help="only this split (train, val, test)")
    ex.set_defaults(func=export_cmd)

    ep = dsub.add_parser(
        "export-episodes",
        help="the pedestrians of a run's episodes (its traces/) as TrajNet++ ndjson, one per episode",
    )
    ep.add_argument("run", help="an evaluation's work folder (or a campaign cell's), holding traces/")
    ep.add_argument("--output", required=True, help="output folder")
    ep.set_defaults(func=export_episodes_cmd)

    ls = dsub.add_parser("ls", help="list datasets: the server's, or with --dir the .npz files of a folder")
    ls.add_argument("--dir", help="a local folder of dataset files (their .json records)")
    ls.add_argument("--json", action="store_true")
    add_connection_args(ls)
    ls.set_defaults(func=ls_cmd)


def import_cmd(args: argparse.Namespace) -> int:
    from foresight.core.predict.scene_import import ImportScenesConfig, import_scenes_to

    if not args.local:
        raise ConfigError(
            "dataset import reads local files: run it with --local (the .npz it writes "
            "serves --local runs: predict-eval --dataset, train --dataset)",
            source="command line",
            item="--local",
        )
    values = scene_values(args, str(Path(args.path).resolve()))
    values.update(max_agents=args.max_agents, test_scene=args.test_scene, val_scene=args.val_scene)
    config = build_config(ImportScenesConfig, values)
    record = import_scenes_to(config, Path(args.output).resolve())
    if args.json:
        print(json.dumps(record, default=str))
    else:
        summary = record["summary"]
        print(f"{args.output}: {summary['samples']} samples {summary.get('samples_per_split', '')}")
    return 0


def export_cmd(args: argparse.Namespace) -> int:
    from foresight.core.predict.dataset import load_dataset
    from foresight.core.predict.scene_import import export_trajnet

    ds = load_dataset(Path(args.dataset))
    if args.split:
        ds = ds.subset(ds.split_indices(args.split))
    n = export_trajnet(ds, Path(args.output))
    print(f"{args.output}: {n} TrajNet++ scenes")
    return 0


def export_episodes_cmd(args: argparse.Namespace) -> int:
    from foresight.core.predict.trace_export import export_episodes

    written = export_episodes(Path(args.run), Path(args.output))
    print(f"{args.output}: {len(written)} TrajNet++ files (one per episode)")
    return 0


class _Samples(BaseModel):
    samples: int | None = None


def ls_cmd(args: argparse.Namespace) -> int:
    if not args.dir:
        from foresight.cli.client import Client, plain, read
        from foresight.schemas import DatasetPublic

        datasets = Client.from_args(args).fetch(list[DatasetPublic], "/v1/datasets")
        if args.json:
            print(json.dumps(plain(datasets)))
            return 0
        for d in datasets:  # a server's record keeps no time base
            print(f"{d.id}  {read(_Samples, d.summary, f'dataset {d.id}: summary').samples} samples")
        return 0
    rows = []
    for rec in sorted(Path(args.dir).glob("*.json")):
        try:
            data = json.loads(rec.read_text())
            meta, summary = data["meta"], data["summary"]
            tb = meta["timebase"]
            if not {"dt", "history", "horizon"} <= set(tb):
                continue
        except (OSError, ValueError, KeyError, TypeError):
            continue  # not a dataset record
        rows.append(
            {
                "path": str(rec.with_suffix(".npz")),
                "samples": summary.get("samples"),
                "source": meta.get("source"),
                "timebase": tb,
                "kind": meta.get("generator", {}).get("kind"),
            }
        )
    if args.json:
        print(json.dumps(rows))
        return 0
    for r in rows:
        tb = r["timebase"]
        print(f"{r['path']}  {r['samples']} samples  dt={tb['dt']} H={tb['history']} T={tb['horizon']}")
    return 0
