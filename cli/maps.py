"""`foresight maps`: inspect, convert (SVG -> our YAML format), render, and re-checksum map registries."""

from __future__ import annotations

import argparse
from pathlib import Path

from foresight.cli.common import emit


def register(sub: argparse._SubParsersAction) -> None:
    maps = sub.add_parser("maps", help="maps: show, convert, render, rehash").add_subparsers(
        dest="action", required=True
    )
    show = maps.add_parser("show", help="summary of a map (SVG or YAML)")
    show.add_argument("path", help="map file: SVG or our YAML map format")
    show.add_argument("--apply-transforms", action="store_true", help="apply SVG transforms (editor view)")
    show.add_argument("--json", action="store_true")
    show.set_defaults(func=show_map)

    conv = maps.add_parser("convert", help="import a map (e.g. a reference SVG) into our YAML format")
    conv.add_argument("path", help="map file: SVG or our YAML map format")
    conv.add_argument("-o", "--output", required=True, help="YAML map file to write")
    conv.add_argument("--apply-transforms", action="store_true", help="apply SVG transforms (editor view)")
    conv.set_defaults(func=convert_map)

    ren = maps.add_parser("render", help="draw a map preview (PNG or SVG)")
    ren.add_argument("path", help="map file: SVG or our YAML map format")
    ren.add_argument("-o", "--output", required=True, help="picture to write (.png or .svg)")
    ren.add_argument("--apply-transforms", action="store_true", help="apply SVG transforms (editor view)")
    ren.set_defaults(func=render_map)

    rehash = maps.add_parser("rehash", help="update source_sha256 of every row of a map registry")
    rehash.add_argument("registry", help="map registry YAML whose checksums to rewrite")
    rehash.add_argument("--check", action="store_true", help="only report stale rows; exit 1 if any")
    rehash.add_argument("--json", action="store_true")
    rehash.set_defaults(func=rehash_registry)


def _load(args: argparse.Namespace):
    from foresight.core.maps.io import load_map

    return load_map(Path(args.path), apply_transforms=args.apply_transforms)


def show_map(args: argparse.Namespace) -> int:
    m = _load(args)
    info = {
        "name": m.name,
        "width": m.width,
        "height": m.height,
        "obstacles": len(m.obstacles),
        "robot_spawn_zones": len(m.robot_spawn_zones),
        "robot_goal_zones": len(m.robot_goal_zones),
        "robot_routes": [round(r.length, 2) for r in m.robot_routes],
        "ped_routes": [round(r.length, 2) for r in m.ped_routes],
        "ped_crowded_zones": len(m.ped_crowded_zones),
        "single_pedestrians": [p.id for p in m.single_pedestrians],
        "pois": sorted(m.pois),
    }
    emit(info, args.json, lambda d: "\n".join(f"{k:<20} {v}" for k, v in d.items()))
    return 0


def convert_map(args: argparse.Namespace) -> int:
    from foresight.core.maps.native import dump_map

    Path(args.output).write_text(dump_map(_load(args)), encoding="utf-8")
    print(f"wrote {args.output}")
    return 0


def render_map(args: argparse.Namespace) -> int:
    from foresight.core.render.map_view import render_map as draw

    draw(_load(args), Path(args.output))
    print(f"wrote {args.output}")
    return 0


def rehash_registry(args: argparse.Namespace) -> int:
    from foresight.core.maps.registry import refresh_checksums

    changed = refresh_checksums(args.registry, write=not args.check)
    rows = {k: {"old": old, "new": new} for k, (old, new) in changed.items()}
    emit(
        rows,
        args.json,
        lambda d: (
            "\n".join(f"{k}: {v['old']} -> {v['new']}" for k, v in d.items()) or "all checksums current"
        ),
    )
    return 1 if args.check and changed else 0
