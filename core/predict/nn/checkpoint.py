"""Checkpoints: one dict holding everything needed to rebuild and trust a model.

Keys: ``format``, ``model_config``, ``model`` (state dict), ``timebase``, ``feature_schema``
({names, frame_convention}), ``dataset`` ({id, sha256, source, config_hash}), ``metrics``, ``epoch``,
``code_version``, and for resuming ``optimizer`` and ``train_state``. Loading rebuilds the model
from the file alone and refuses a file whose format, feature layout or time base does not match.
"""

from __future__ import annotations

import hashlib
import io
from pathlib import Path
from typing import Any

import numpy as np
import torch

from foresight.core import files
from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.predict.features import feature_names
from foresight.core.predict.nn.device import to_cpu
from foresight.core.predict.nn.inference import ModelForward
from foresight.core.predict.nn.mirror import mirror_mean, mirror_mixture
from foresight.core.predict.nn.model import ModelConfig, TrajectoryModel, build_model, weighted_modes
from foresight.core.predict.nn.modes import MODE_TOP, first_on_top
from foresight.core.predict.predictor import check_batch
from foresight.core.predict.timebase import TimeBase
from foresight.core.version import code_version

FORMAT = "foresight.predict.checkpoint/1"
REQUIRED = (
    "format",
    "model_config",
    "model",
    "timebase",
    "feature_schema",
    "dataset",
    "metrics",
    "epoch",
    "code_version",
)


def make_checkpoint(
    model: TrajectoryModel,
    timebase: TimeBase,
    frame_convention: str,
    dataset: dict[str, Any],
    metrics: dict[str, Any],
    epoch: int,
    **extra: Any,
) -> dict[str, Any]:
    """The checkpoint dict of ``model``; its weights on the CPU whatever device trained it, so the file loads
    anywhere in the same format."""
    return {
        "format": FORMAT,
        "model_config": model.config.to_dict(),
        "model": to_cpu(model.state_dict()),
        "timebase": timebase.to_dict(),
        "feature_schema": {"names": feature_names(timebase.history), "frame_convention": frame_convention},
        "dataset": dataset,
        "metrics": metrics,
        "epoch": epoch,
        "code_version": code_version(),
        **extra,
    }


def save_checkpoint(payload: dict[str, Any], path: Path) -> None:
    """Atomic write (temp file + rename), so an interrupted save never leaves a half file."""
    with files.replacing(path) as tmp:
        torch.save(payload, tmp)


def checkpoint_bytes(path: Path, expect_sha256: str | None = None) -> tuple[bytes, str]:
    """The file's bytes and their sha256, read once (what is hashed is what gets loaded); a checksum other
    than ``expect_sha256`` is a ConfigError, so a checkpoint rewritten in place is never used silently."""
    path = Path(path)
    if not path.is_file():
        raise NotFoundError(f"checkpoint {path} does not exist")
    data = path.read_bytes()
    sha = hashlib.sha256(data).hexdigest()
    if expect_sha256 is not None and sha != expect_sha256:
        raise ConfigError(
            f"checkpoint content changed: sha256 {sha[:12]}... instead of {expect_sha256[:12]}...",
            source=path,
            item="sha256",
        )
    return data, sha


def read_checkpoint(path: Path, expect_sha256: str | None = None) -> dict[str, Any]:
    """The checkpoint dict (format and required keys checked); ``expect_sha256`` as in :func:`checkpoint_bytes`."""
    return _decode(checkpoint_bytes(path, expect_sha256)[0], Path(path))


def _decode(data: bytes, path: Path) -> dict[str, Any]:
    try:
        payload = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - foreign bytes make torch.load raise KeyError, UnpicklingError, ...
        raise ConfigError(f"not a readable checkpoint ({exc})", source=path) from None
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        raise ConfigError(f"not a {FORMAT} checkpoint", source=path, item="format")
    missing = [k for k in REQUIRED if k not in payload]
    if missing:
        raise ConfigError(f"checkpoint lacks {', '.join(missing)}", source=path, item=missing[0])
    return payload


class TorchPredictor:
    """A trained model behind the :class:`core.predict.predictor.Predictor` interface (numpy in/out).

    One sample (B = 1: a planner decision) runs the NumPy copy of the forward pass (``inference``: the weights are
    read at the first such call, so the model must be trained by then); batches run the torch model.
    """

    def __init__(
        self,
        model: TrajectoryModel,
        timebase: TimeBase,
        name: str,
        frame_convention: str = "robot",
        max_agents: int | None = None,
        threads: int | None = None,
        sha256: str | None = None,
    ):
        self.model = model.eval()
        self.sha256 = sha256  #: checksum of the checkpoint bytes this model was built from
        self.timebase = timebase
        self.name = name
        self.frame_convention = frame_convention
        self.max_agents = max_agents
        self._numpy: ModelForward | None = None
        if threads:
            torch.set_num_threads(threads)

    @property
    def has_sigma(self) -> bool:
        """Whether the model predicts its own spread (a sigma head); else forecasts use a calibrated envelope."""
        return bool(getattr(self.model.config, "sigma_head", False))

    @property
    def mirror_average(self) -> bool:
        """Whether forecasts average the network with its mirror twin (``core.predict.nn.mirror``)."""
        return bool(getattr(self.model.config, "mirror_average", False))

    @property
    def n_modes(self) -> int:
        """Modes per pedestrian the model forecasts (``predict_modes``); 1 for a deterministic model."""
        return int(getattr(self.model.config, "modes", 1))

    def predict_modes(self, features: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B, N, K, T, 2) modes and (B, N, K) weights summing to 1 (``core.predict.nn.modes``), mode 0 the most
        likely unless the model's ``mode_top`` is "weight" (then the weight head's as they are). Mode 0 is
        :meth:`predict`'s forecast, to the bit: with mirror averaging the mirror mean, while the other modes and the
        weights are the network's own (a WTA mode has no mirror partner to average with). The other modes run the
        torch model (the NumPy copy of one decision's forward holds mode 0 only)."""
        check_batch(np.asarray(features), np.asarray(mask), self.timebase, self.name)
        if self.n_modes == 1:
            pos = self.predict(features, mask)
            return pos[:, :, None], np.ones(pos.shape[:2] + (1,))
        with torch.inference_mode():
            modes, weights = weighted_modes(
                self.model,
                torch.as_tensor(features, dtype=torch.float32),
                torch.as_tensor(mask, dtype=torch.float32),
            )
        modes, weights = modes.numpy(), weights.numpy().astype(np.float64)
        if getattr(self.model.config, "mode_top", "first") == "first":  # mode 0 ranked most likely
            weights = first_on_top(weights)
        weights /= weights.sum(-1, keepdims=True)
        modes[:, :, 0] = self.predict(features, mask)  # exactly predict()'s (its NumPy path, its mirror mean)
        return modes, weights

    def predict(self, features: np.ndarray, mask: np.ndarray) -> np.ndarray:
        check_batch(np.asarray(features), np.asarray(mask), self.timebase, self.name)
        if self.mirror_average:
            return mirror_mean(self._predict, np.asarray(features, np.float32), mask, self.timebase.history)
        return self._predict(features, mask)

    def _predict(self, features: np.ndarray, mask: np.ndarray) -> np.ndarray:
        if len(features) == 1:
            return self._one_sample().positions(*_sample(features, mask))[None]
        with torch.inference_mode():
            out = self.model(
                torch.as_tensor(features, dtype=torch.float32), torch.as_tensor(mask, dtype=torch.float32)
            )
        return out.numpy()

    def predict_dist(self, features: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B, N, T, 2) positions and (B, N, T) per-axis std [m]; only when :attr:`has_sigma`."""
        check_batch(np.asarray(features), np.asarray(mask), self.timebase, self.name)
        if self.mirror_average:
            return mirror_mixture(
                self._predict_dist, np.asarray(features, np.float32), mask, self.timebase.history
            )
        return self._predict_dist(features, mask)

    def _predict_dist(self, features: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if len(features) == 1:
            pos, sigma = self._one_sample().distribution(*_sample(features, mask))
            return pos[None], sigma[None]
        with torch.inference_mode():
            pos, sigma = self.model.forward_dist(
                torch.as_tensor(features, dtype=torch.float32), torch.as_tensor(mask, dtype=torch.float32)
            )
        return pos.numpy(), sigma.numpy()

    def _one_sample(self) -> ModelForward:
        if self._numpy is None:
            self._numpy = ModelForward(self.model)
        return self._numpy


def _sample(features: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The one sample of a batch as float32 arrays (N, F), (N,)."""
    return np.asarray(features[0], dtype=np.float32), np.asarray(mask[0], dtype=np.float32)


def load_predictor(
    path: Path,
    expect_timebase: TimeBase | None = None,
    name: str | None = None,
    threads: int | None = 1,
    expect_sha256: str | None = None,
) -> TorchPredictor:
    """Rebuild the model from the checkpoint alone; ``expect_timebase`` makes a mismatch an error, and so
    does ``expect_sha256`` (checked on the very bytes loaded; the result's ``sha256`` holds their checksum).

    ``threads`` sets torch's (process-wide) thread count: one per process by default, because a decision
    is a batch of a few pedestrians where threads only add contention (136-415 ms per decision was
    measured with the default count on a loaded 2-core machine, ~0.2 ms with one).
    """
    data, sha = checkpoint_bytes(path, expect_sha256)
    payload = _decode(data, Path(path))
    timebase = TimeBase.from_dict(payload["timebase"], source=str(path))
    if expect_timebase is not None:
        expect_timebase.require_same(timebase, what=f"checkpoint {path}", source=str(path))
    schema = payload["feature_schema"]
    if schema.get("names") != feature_names(timebase.history):
        raise ConfigError(
            "feature schema differs from this code's feature extraction; retrain the model",
            source=path,
            item="feature_schema",
        )
    try:
        config = ModelConfig(**payload["model_config"])
    except TypeError as exc:
        raise ConfigError(f"bad model_config ({exc})", source=path, item="model_config") from None
    if config.mode_top not in MODE_TOP:
        raise ConfigError(
            f"model_config.mode_top must be one of {', '.join(MODE_TOP)}, got {config.mode_top!r}",
            source=path,
            item="model_config",
        )
    if (config.history, config.horizon) != (timebase.history, timebase.horizon) or abs(
        config.dt - timebase.dt
    ) > 1e-9:
        raise ConfigError(
            "model_config disagrees with the checkpoint's time base", source=path, item="model_config"
        )
    model = build_model(config)
    try:
        model.load_state_dict(payload["model"], strict=True)
    except RuntimeError as exc:
        raise ConfigError(
            f"weights do not fit model_config ({str(exc).splitlines()[0]})", source=path, item="model"
        ) from None
    max_agents = payload.get("dataset", {}).get("max_agents")
    return TorchPredictor(
        model,
        timebase,
        name or Path(path).stem,
        schema.get("frame_convention", "robot"),
        max_agents,
        threads=threads,
        sha256=sha,
    )
