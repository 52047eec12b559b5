"""Reading an ETH/UCY scene file (rows of frame, pedestrian id, x, y): what a replay scenario plays and what
the predictor's fold import (``core.predict.ethucy``) turns into samples."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from foresight.core.errors import ConfigError


def read_scene(path: Path) -> np.ndarray:
    """(R, 4) rows frame, ped_id, x, y [m] of a tab/space separated file."""
    try:
        rows = np.loadtxt(path, dtype=np.float64, ndmin=2)
    except ValueError as exc:
        raise ConfigError(f"not an ETH/UCY file (frame ped_id x y): {exc}", source=path) from None
    if rows.shape[1] != 4 or not np.isfinite(rows).all():
        raise ConfigError(f"expected 4 finite columns, got shape {rows.shape}", source=path)
    return rows
