"""Checkpoint selection: by (proxy success, proxy clearance, -validation loss) once a proxy
evaluation exists, by validation loss before that (``val_loss_fallback``) or without a proxy."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any


def _proxy_key(rec: dict[str, Any]) -> tuple[float, float, float]:
    p = rec["proxy"]
    clearance = p.get("clearance", -math.inf)
    clearance = clearance if clearance is not None and math.isfinite(clearance) else -math.inf
    return (float(p.get("success", 0.0)), clearance, -rec["val_loss"])


@dataclass
class Selection:
    proxy_enabled: bool = False
    best: dict[str, Any] | None = None
    mode: str = "none"  #: val_loss | val_loss_fallback | proxy
    reason: str = ""
    proxy_history: list[dict[str, Any]] = field(default_factory=list)

    def offer(self, rec: dict[str, Any]) -> bool:
        """Consider one epoch's record; True when it becomes the selected checkpoint."""
        if "proxy" in rec:
            self.proxy_history.append({"epoch": rec["epoch"], **rec["proxy"], "val_loss": rec["val_loss"]})
            if self.mode != "proxy" or _proxy_key(rec) > _proxy_key(self.best):
                return self._take(rec, "proxy", "best (proxy success, proxy clearance, -val loss)")
            return False
        if self.mode == "proxy":
            return False  # once a proxy pick exists, validation loss alone no longer replaces it
        if self.best is None or rec["val_loss"] < self.best["val_loss"]:
            mode = "val_loss_fallback" if self.proxy_enabled else "val_loss"
            return self._take(
                rec,
                mode,
                "lowest validation loss" + (" before the first proxy epoch" if self.proxy_enabled else ""),
            )
        return False

    def _take(self, rec: dict[str, Any], mode: str, reason: str) -> bool:
        self.best, self.mode, self.reason = dict(rec), mode, reason
        return True

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Selection:
        return cls(**d)
