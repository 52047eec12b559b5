"""Typed references used in stage configs: ids and bundle-relative paths, never server paths."""

from __future__ import annotations

from pathlib import Path, PurePosixPath
from typing import Annotated

from pydantic import AfterValidator, Field

from foresight.core.limits import MAX_NAME_BYTES

#: The project's own configs/ folder, registered by the service as bundle "builtin".
BUILTIN_BUNDLE = "builtin"
BUILTIN_CONFIG_ROOT = Path(__file__).resolve().parent.parent.parent / "configs"


def _relative(value: str) -> str:
    p = PurePosixPath(value.replace("\\", "/"))
    if not p.parts:
        raise ValueError("path is empty")
    if p.is_absolute() or ".." in p.parts or value.startswith("~") or ":" in p.parts[0]:
        raise ValueError(f"{value!r} must be a path relative to its bundle root, without '..'")
    long = next(
        (part for part in p.parts if len(part.encode("utf-8", "surrogatepass")) > MAX_NAME_BYTES), None
    )
    if long is not None:  # no file system holds it: reading it failed with an OSError (a 500)
        raise ValueError(f"a file or folder name over {MAX_NAME_BYTES} bytes: {long[:40]!r}...")
    return p.as_posix()


#: A path inside a config bundle (relative, no '..'): e.g. "scenarios/classic_interactions.yaml".
BundlePath = Annotated[str, Field(min_length=1, max_length=500), AfterValidator(_relative)]

#: Model ids that name a rule, not a registered model: the constant-velocity forecaster, the static forecaster
#: (everyone stays where they are: CrowdNav++'s prediction ``none``), no model, and the default model (whichever
#: the registry's rule picks). A registered model never takes one of them.
CV = "cv"
STATIC = "static"
NO_MODEL = "none"
DEFAULT_MODEL = "default"
#: The forecasts built by rule, needing no model file: the predictive planner takes either by name.
FORECAST_RULES = frozenset({CV, STATIC})
RESERVED_MODEL_IDS = frozenset({CV, STATIC, NO_MODEL, DEFAULT_MODEL})

#: An id of a stored object (bundle, dataset, model, job): letters, digits, '.', '_', '-', ':'.
Ident = Annotated[str, Field(min_length=1, max_length=200, pattern=r"^[A-Za-z0-9][A-Za-z0-9._:\-]*$")]

#: A name inside a file (scenario, variant): printable, no control characters (a NUL broke stored text).
Name = Annotated[str, Field(min_length=1, max_length=200, pattern=r"^[^\x00-\x1f\x7f]+$")]
#: A seed: what numpy's SeedSequence and every database integer column hold.
Seed = Annotated[int, Field(ge=0, le=2**31 - 1)]


def resolve_in_bundle(root: Path, rel: str) -> Path:
    """Join a bundle-relative path to its root and check it stays inside (symlinks resolved)."""
    root = root.resolve()
    path = (root / rel).resolve()
    if path != root and root not in path.parents:
        raise ValueError(f"{rel!r} escapes its bundle")
    return path
