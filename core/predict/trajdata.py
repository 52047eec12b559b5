"""Your own trajectory data: TrajNet++ ndjson and plain text/CSV (``frame id x y``) as scenes of annotated rows.

A scene is one file (a folder holds one per file, sorted by name); its rows are (frame, pedestrian id, x, y) in
metres. Files are read line by line (a running array of parsed rows, never the whole text), and any malformed line
is one ConfigError naming the file, the line and what was expected. Declared by the importer, never guessed:
``frame_interval`` [s] between consecutive annotated frames, ``frame_step`` (frame-number units per annotation;
default: the smallest gap between a file's distinct frames), ``units`` of the coordinates, and for text the column
order (``columns``: a permutation naming frame, id, x, y; other names are skipped columns).

- TrajNet++: ``{"track": {"f": frame, "p": id, "x": x, "y": y}}`` lines are the rows; ``{"scene": ...}`` lines
  (the benchmark's windows) are read for their ``fps`` only, which must agree with ``frame_interval``;
- text/CSV: comma, tab or space separated; ``#`` lines and blank lines are skipped.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from foresight.core.errors import ConfigError, NotFoundError

FORMATS = ("trajnet", "text")
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
NEEDED = ("frame", "id", "x", "y")
SUFFIXES = {"trajnet": (".ndjson", ".json"), "text": (".txt", ".csv", ".tsv")}
_SPLIT = re.compile(r"[,\s]+")
_CHUNK = 65536  #: rows parsed before they join the array (bounds the Python objects alive at once)


def scene_files(path: Path, fmt: str) -> list[Path]:
    """One file, or a folder's files of the format (sorted by name); NotFoundError / ConfigError when there are none."""
    if fmt not in FORMATS:
        raise ConfigError(f"unknown format {fmt!r}; expected one of {', '.join(FORMATS)}", item="format")
    path = Path(path)
    if path.is_file():
        return [path]
    if not path.is_dir():
        raise NotFoundError(f"{path} does not exist")
    files = sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() in SUFFIXES[fmt])
    if not files:
        raise ConfigError(f"no {' / '.join(SUFFIXES[fmt])} files in the folder", source=path, item="format")
    return files


def parse_columns(columns: str | list[str]) -> list[str]:
    """The column names of a text file in order: frame, id, x and y each exactly once (others are skipped)."""
    names = [c.strip() for c in columns.split(",")] if isinstance(columns, str) else list(columns)
    missing = [n for n in NEEDED if names.count(n) != 1]
    if missing:
        raise ConfigError(
            f"columns {names} must name each of frame, id, x, y exactly once (missing or repeated: {missing})",
            item="columns",
        )
    return names


class _Rows:
    """Parsed rows, gathered chunk by chunk into one float64 array (R, 4)."""

    def __init__(self) -> None:
        self.parts: list[np.ndarray] = []
        self.chunk: list[tuple[float, float, float, float]] = []

    def add(self, row: tuple[float, float, float, float]) -> None:
        self.chunk.append(row)
        if len(self.chunk) >= _CHUNK:
            self.flush()

    def flush(self) -> None:
        if self.chunk:
            self.parts.append(np.asarray(self.chunk, dtype=np.float64))
            self.chunk = []

    def array(self) -> np.ndarray:
        self.flush()
        return np.concatenate(self.parts) if self.parts else np.zeros((0, 4))


def read_text(path: Path, columns: list[str]) -> np.ndarray:
    """Rows (frame, id, x, y) of a text/CSV file in the given column order."""
    where = [columns.index(n) for n in NEEDED]
    width = len(columns)
    rows = _Rows()
    with open(path, encoding="utf-8", errors="strict") as f:
        try:
            for no, line in enumerate(f, 1):
                text = line.strip()
                if not text or text.startswith("#"):
                    continue
                cells = [c for c in _SPLIT.split(text) if c]
                if len(cells) != width:
                    raise ConfigError(
                        f"line {no}: {len(cells)} columns, expected {width} ({', '.join(columns)})",
                        source=path,
                        item=f"line {no}",
                    )
                try:
                    values = tuple(float(cells[i]) for i in where)
                except ValueError:
                    if no == 1 and rows.parts == [] and rows.chunk == []:  # a header line
                        continue
                    raise ConfigError(
                        f"line {no}: expected numbers in columns {', '.join(NEEDED)}, got {text[:80]!r}",
                        source=path,
                        item=f"line {no}",
                    ) from None
                rows.add(values)
        except UnicodeDecodeError as exc:
            raise ConfigError(f"not UTF-8 text ({exc.reason})", source=path) from None
    return rows.array()


def read_trajnet(path: Path) -> tuple[np.ndarray, set[float]]:
    """Rows (frame, id, x, y) of a TrajNet++ ndjson file and the ``fps`` values its scene lines declare."""
    rows = _Rows()
    fps: set[float] = set()
    with open(path, encoding="utf-8", errors="strict") as f:
        try:
            for no, line in enumerate(f, 1):
                if not line.strip():
                    continue
                try:
                    rec = json.loads(line)
                except json.JSONDecodeError as exc:
                    raise ConfigError(
                        f"line {no}: not JSON ({exc.msg}); expected one TrajNet++ record per line",
                        source=path,
                        item=f"line {no}",
                    ) from None
                track = rec.get("track") if isinstance(rec, dict) else None
                if isinstance(track, dict):
                    try:
                        rows.add((float(track["f"]), float(track["p"]), float(track["x"]), float(track["y"])))
                    except (KeyError, TypeError, ValueError):
                        raise ConfigError(
                            f"line {no}: a track needs numeric f, p, x, y; got {line.strip()[:80]!r}",
                            source=path,
                            item=f"line {no}",
                        ) from None
                elif isinstance(rec, dict) and isinstance(rec.get("scene"), dict):
                    if "fps" in rec["scene"]:
                        fps.add(float(rec["scene"]["fps"]))
                else:
                    raise ConfigError(
                        f'line {no}: expected {{"track": ...}} or {{"scene": ...}}, got {line.strip()[:80]!r}',
                        source=path,
                        item=f"line {no}",
                    )
        except UnicodeDecodeError as exc:
            raise ConfigError(f"not UTF-8 text ({exc.reason})", source=path) from None
    return rows.array(), fps


def normalise(rows: np.ndarray, path: Path, frame_step: float | None, units: str) -> tuple[np.ndarray, float]:
    """Rows renumbered so consecutive annotations are ``frame_step`` apart as given (or inferred), coordinates in
    metres, sorted by frame then id; duplicate (frame, id) rows and non-finite values are errors."""
    if units not in UNITS:
        raise ConfigError(f"unknown units {units!r}; expected one of {', '.join(UNITS)}", item="units")
    if not len(rows):
        raise ConfigError("no trajectory rows", source=path)
    if not np.isfinite(rows).all():
        bad = int(np.flatnonzero(~np.isfinite(rows).all(axis=1))[0])
        raise ConfigError(f"row {bad + 1} holds a non-finite value", source=path)
    rows = rows[np.lexsort((rows[:, 1], rows[:, 0]))]
    frames = np.unique(rows[:, 0])
    step = frame_step
    if step is None:
        gaps = np.diff(frames)
        step = float(gaps.min()) if len(gaps) else 1.0
    if step <= 0:
        raise ConfigError(f"frame step must be > 0, got {step}", source=path, item="frame_step")
    k = (rows[:, 0] - frames[0]) / step
    if np.any(np.abs(k - np.rint(k)) > 1e-6):
        raise ConfigError(
            f"frames are not whole multiples of the frame step {step:g} from the first frame", source=path
        )
    same = (np.diff(rows[:, 0]) == 0) & (np.diff(rows[:, 1]) == 0)
    if same.any():
        i = int(np.flatnonzero(same)[0])
        raise ConfigError(
            f"pedestrian {rows[i, 1]:g} appears twice in frame {rows[i, 0]:g}", source=path, item="rows"
        )
    rows[:, 0] = np.rint(
        k
    )  # consecutive annotations are 1 apart (``rows`` is the sorted copy: the input is kept)
    rows[:, 2:] *= UNITS[units]
    return rows, step


def read_scene_file(
    path: Path,
    fmt: str,
    frame_interval: float,
    columns: list[str] | None = None,
    frame_step: float | None = None,
    units: str = "m",
) -> np.ndarray:
    """Rows (frame index, id, x [m], y [m]) of one scene file, consecutive annotations 1 apart (``normalise``)."""
    if fmt == "trajnet":
        rows, fps = read_trajnet(path)
        for rate in fps:
            if rate > 0 and abs(1.0 / rate - frame_interval) > 1e-6 * max(1.0, frame_interval):
                raise ConfigError(
                    f"its scenes declare fps {rate:g} ({1.0 / rate:g} s per frame) but the import declares a frame "
                    f"interval of {frame_interval:g} s",
                    source=path,
                    item="frame_interval",
                )
    else:
        rows = read_text(path, columns or list(NEEDED))
    return normalise(rows, path, frame_step, units)[0]
