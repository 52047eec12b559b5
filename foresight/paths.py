"""The one rule for a config path a user types (a matrix, seed manifest, grid, training or planner YAML).

A path is read as typed, against the current folder. Where no such file exists, a path that names one of the
project's own configs (``configs/scenarios/x.yaml`` or ``scenarios/x.yaml``) means that file, from any folder.
A file that is a copy of an installed config (another checkout's ``configs/...``) is that config, so the server
reads it by name. Errors name what was typed and the folder it was resolved against.
"""

from __future__ import annotations

import os
from pathlib import Path, PurePosixPath

from foresight.core.errors import ConfigError
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT


def _builtin(rel: PurePosixPath) -> Path | None:
    """The installed config at ``rel`` (with or without a leading ``configs/``), if there is one."""
    parts = rel.parts
    if parts and parts[0] == "configs":
        parts = parts[1:]
    if not parts or ".." in parts:
        return None
    path = BUILTIN_CONFIG_ROOT.joinpath(*parts)
    return path if path.is_file() else None


def user_file(value: str, flag: str) -> Path:
    """The local file ``value`` names: as typed (from the current folder), else the installed config of that
    name; a ConfigError naming the value, the flag and the current folder when neither exists."""
    p = Path(value).expanduser()
    if p.is_file():
        return p.resolve()
    if not p.is_absolute():
        found = _builtin(PurePosixPath(value.replace("\\", "/")))
        if found is not None:
            return found
    raise ConfigError(
        f"no file {value!r} in {os.getcwd()} and no project config of that name (e.g. "
        f"configs/scenarios/classic_interactions.yaml)",
        source="command line",
        item=flag,
    )


def builtin_name(path: Path) -> str | None:
    """The name inside the builtin bundle of a local file that is an installed config or an identical copy of one
    (found by the part of its path after a folder called ``configs``); None for any other file."""
    path = path.resolve()
    root = BUILTIN_CONFIG_ROOT.resolve()
    if root in path.parents:
        return path.relative_to(root).as_posix()
    parts = path.parts
    for i in range(len(parts) - 2, -1, -1):
        if parts[i] != "configs":
            continue
        found = _builtin(PurePosixPath(*parts[i + 1 :]))
        if found is not None and found.read_bytes() == path.read_bytes():
            return found.relative_to(root).as_posix()
    return None


def bundle_name(value: str, flag: str) -> str:
    """The builtin-bundle name of a path typed for a server job: an installed config (or a copy of one), or a name
    that exists neither here nor there, sent as typed for the server to check against its own configs."""
    p = Path(value).expanduser()
    if p.is_file():
        name = builtin_name(p)
        if name is None:
            raise ConfigError(
                f"{value!r} is a local file outside the project's configs/; the server reads "
                "config bundles: upload its folder (`foresight bundles upload NAME FOLDER`) and pass "
                "--bundle NAME with names inside it, or run in-process with --local",
                source="command line",
                item=flag,
            )
        return name
    found = None if p.is_absolute() else _builtin(PurePosixPath(value.replace("\\", "/")))
    return found.relative_to(BUILTIN_CONFIG_ROOT).as_posix() if found is not None else value
