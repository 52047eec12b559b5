"""The torch device training runs on (``TrainConfig.device``), and moving what a checkpoint holds back to the CPU.

The device is resolved where training runs, not where a job is submitted: a Ray task placed on a GPU node sees the
GPU Ray gave it (``CUDA_VISIBLE_DEVICES``), an API server or a CPU-only task sees none.
"""

from __future__ import annotations

from typing import Any

import torch

from foresight.core.errors import ConfigError


def resolve_device(requested: str) -> torch.device:
    """``auto``: cuda when torch sees a GPU, else cpu; ``cuda`` without a GPU is a ConfigError naming ``device``."""
    if requested == "cpu" or (requested == "auto" and not torch.cuda.is_available()):
        return torch.device("cpu")
    if not torch.cuda.is_available():
        raise ConfigError(
            f"device: cuda, but torch {torch.__version__} sees no CUDA GPU here (use device: auto or cpu)",
            item="device",
        )
    return torch.device("cuda")


def to_cpu(value: Any) -> Any:
    """``value`` with every tensor in it (nested dicts, lists, tuples) on the CPU; containers keep their type and
    a tensor already there is the same object, so a CPU run saves exactly what it saved before devices existed."""
    if isinstance(value, torch.Tensor):
        return value.cpu()
    if isinstance(value, dict):
        out = type(value)((k, to_cpu(v)) for k, v in value.items())
        if hasattr(value, "_metadata"):  # a module's state_dict carries its version record
            out._metadata = value._metadata
        return out
    if type(value) in (list, tuple):
        return type(value)(to_cpu(v) for v in value)
    return value
