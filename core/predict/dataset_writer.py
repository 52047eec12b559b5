"""A prediction dataset written chunk by chunk, in memory bounded by one chunk, as the same file ``save_dataset``
writes (``load_dataset`` and everything downstream read it unchanged).

Each chunk of windows is checked (``Dataset.validate``), appended to one raw file per array in a temporary folder
beside the output and counted into the summary (``SummaryStats``); ``finish`` streams the raw files into the
``.npz`` members (``<array>.npy``: a .npy header with the final row count, then the bytes, deflated) through a
temporary name renamed into place, then writes the ``.json`` record. A failed import leaves neither file behind,
and the temporary folder is removed either way.
"""

from __future__ import annotations

import json
import shutil
import tempfile
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from foresight.core import files
from foresight.core.predict.dataset import ARRAYS, Dataset, DatasetMeta, file_sha256
from foresight.core.predict.features import feature_dim
from foresight.core.predict.quality import SummaryStats
from foresight.core.predict.samples import SampleArrays

DTYPES = {
    "state": np.float32,
    "target": np.float32,
    "mask": np.float32,
    "target_mask": np.float32,
    "episode": np.int64,
}


class DatasetWriter:
    """``with DatasetWriter(path, meta) as w: w.add(episode, windows) ...; record = w.finish()``."""

    def __init__(self, path: Path, meta: DatasetMeta) -> None:
        self.path = Path(path)
        self.meta = meta
        self.count = 0
        self.stats = SummaryStats(len(meta.episodes))
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._tmp = tempfile.TemporaryDirectory(
            prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent
        )
        self._raw = {name: open(Path(self._tmp.name) / name, "wb") for name in ARRAYS}  # noqa: SIM115
        self._empty().validate(str(self.path))  # the metadata alone (frame convention, feature names)

    def __enter__(self) -> DatasetWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        for fh in self._raw.values():
            fh.close()
        self._tmp.cleanup()

    def _empty(self) -> Dataset:
        N, T, F = self.meta.max_agents, self.meta.timebase.horizon, feature_dim(self.meta.timebase.history)
        shapes = {"state": (0, N, F), "target": (0, N, T, 2), "mask": (0, N), "target_mask": (0, N, T)}
        arrays = {k: np.zeros(s, DTYPES[k]) for k, s in shapes.items()}
        return Dataset(**arrays, episode=np.zeros(0, np.int64), meta=self.meta)

    def add(self, episode: int, windows: SampleArrays) -> None:
        """Append the windows of episode ``episode`` (its row in ``meta.episodes``)."""
        n = len(windows.state)
        chunk = Dataset(
            **{k: np.ascontiguousarray(getattr(windows, k), DTYPES[k]) for k in ARRAYS if k != "episode"},
            episode=np.full(n, episode, np.int64),
            meta=self.meta,
        ).validate(str(self.path))
        for name in ARRAYS:
            self._raw[name].write(getattr(chunk, name).tobytes())
        self.stats.add(chunk)
        self.count += n

    def finish(self) -> dict[str, Any]:
        """Write the ``.npz`` and its ``.json`` record (as ``save_dataset`` does); return the record."""
        for fh in self._raw.values():
            fh.close()
        empty = self._empty()
        meta_json = np.array(json.dumps(self.meta.to_json(), sort_keys=True))
        with (
            files.replacing(self.path) as tmp,
            zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED, allowZip64=True) as zf,
        ):
            for name in ARRAYS:
                header = {
                    "descr": np.lib.format.dtype_to_descr(np.dtype(DTYPES[name])),
                    "fortran_order": False,
                    "shape": (self.count, *getattr(empty, name).shape[1:]),
                }
                with (
                    zf.open(f"{name}.npy", "w", force_zip64=True) as out,
                    open(self._raw[name].name, "rb") as src,
                ):
                    np.lib.format.write_array_header_1_0(out, header)
                    shutil.copyfileobj(src, out, 1 << 20)
            with zf.open("meta_json.npy", "w", force_zip64=True) as out:
                np.lib.format.write_array(out, meta_json, allow_pickle=False)
        record = {
            "path": str(self.path),
            "sha256": file_sha256(self.path),
            "meta": self.meta.to_json(),
            "summary": self.stats.result(self.meta.episodes),
        }
        files.write_text(self.path.with_suffix(".json"), json.dumps(record, indent=2, sort_keys=True))
        return record
