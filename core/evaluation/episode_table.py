"""Episodes as a table: every field of every episode record, flat (``safety.min_clearance``), one row per episode.

The records stay nested in ``episodes.jsonl`` (one record audits itself); analysis tools want columns. CSV and JSON
lines need nothing; Parquet needs pyarrow (the ``parquet`` extra). Lists (taxonomy tags, a collision point) are lists
in JSON lines and Parquet and JSON text in CSV. An evaluation's whole ``episodes.jsonl`` goes to Parquet through
pyarrow's JSON reader (10,000 episodes in well under a second: bench/episode_export.py).
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from foresight.core.errors import ConfigError

FORMATS = ("csv", "parquet", "jsonl")
MEDIA_TYPES = {
    "csv": "text/csv",
    "parquet": "application/vnd.apache.parquet",
    "jsonl": "application/x-ndjson",
}


def flat(record: Any, prefix: str = "", *, lists_as_text: bool = False) -> dict[str, Any]:
    """One record (a dict or a pydantic model) as ``{dotted.key: value}``."""
    if hasattr(record, "model_dump"):
        record = record.model_dump(mode="json")
    out: dict[str, Any] = {}
    for key, value in record.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flat(value, name + ".", lists_as_text=lists_as_text))
        elif lists_as_text and isinstance(value, list | tuple):
            out[name] = json.dumps(value)
        else:
            out[name] = value
    return out


def rows_of(records: Iterable[Any], *, lists_as_text: bool = False) -> tuple[list[str], list[dict[str, Any]]]:
    """(columns in first-seen order, flat rows)."""
    rows = [flat(r, lists_as_text=lists_as_text) for r in records]
    columns: dict[str, None] = {}
    for row in rows:
        columns.update(dict.fromkeys(row))
    return list(columns), rows


def read_jsonl(path: str | Path) -> list[dict[str, Any]]:
    """The records of an ``episodes.jsonl`` as plain dicts (no model validation: an export reads what is there)."""
    with Path(path).open(encoding="utf-8") as fh:
        return [json.loads(line) for line in fh if line.strip()]


def table_format(value: str | None, path: str | Path | None = None) -> str:
    """The format asked for, else the one a file's suffix names; ConfigError for anything else."""
    fmt = value or (Path(path).suffix.lower().lstrip(".") if path else "csv")
    fmt = {"ndjson": "jsonl", "pq": "parquet"}.get(fmt, fmt)
    if fmt not in FORMATS:
        raise ConfigError(f"expected one of {', '.join(FORMATS)}, got {fmt!r}", item="format")
    return fmt


def encode(records: Iterable[Any], fmt: str) -> bytes:
    """The table of ``records`` as bytes in ``fmt`` (csv, parquet, jsonl)."""
    columns, rows = rows_of(records, lists_as_text=fmt == "csv")
    if fmt == "jsonl":
        return "".join(json.dumps({c: row.get(c) for c in columns}) + "\n" for row in rows).encode()
    if fmt == "csv":
        text = io.StringIO()
        writer = csv.DictWriter(text, fieldnames=columns, restval="", lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        return text.getvalue().encode()
    if fmt == "parquet":
        pa = _pyarrow()
        return _parquet(pa.Table.from_pydict({c: [row.get(c) for row in rows] for c in columns}))
    raise ConfigError(f"expected one of {', '.join(FORMATS)}, got {fmt!r}", item="format")


def _pyarrow() -> Any:
    try:
        import pyarrow
        import pyarrow.json
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        raise ConfigError("Parquet needs pyarrow: pip install 'foresight[parquet]'", item="format") from None
    return pyarrow


def _parquet(table: Any) -> bytes:
    import pyarrow.parquet as pq

    sink = _pyarrow().BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


def export_jsonl(path: str | Path, fmt: str) -> bytes:
    """The table of a whole ``episodes.jsonl`` in ``fmt``; Parquet read and flattened by pyarrow in one block
    (so every column's type is inferred from every record)."""
    if fmt != "parquet":
        return encode(read_jsonl(path), fmt)
    pa = _pyarrow()
    size = Path(path).stat().st_size
    if size == 0:
        return encode([], fmt)
    table = pa.json.read_json(str(path), read_options=pa.json.ReadOptions(block_size=size + 1))
    while any(pa.types.is_struct(field.type) for field in table.schema):
        table = table.flatten()  # one level per call: safety.min_clearance, taxonomy.label, ...
    return _parquet(table)
