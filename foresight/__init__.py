"""Foresight: a service platform for predictive local planners in crowd navigation.

The repository's top-level folders install under this one namespace (see ``setup.py``):
``foresight.core`` (the pure library), ``foresight.store``, ``foresight.api``, ``foresight.worker``, ``foresight.cli``, and the
run-time data the service needs: ``foresight.migrations``, ``foresight.configs``, ``foresight.model``.

For notebooks and scripts: ``foresight.evaluate(planner, ...)`` and ``foresight.simulate(planner, ...)``
(``foresight.library``); with gymnasium installed, ``import foresight.core.gym`` (or importing gymnasium
before foresight) registers the environment ``foresight/CrowdNav-v0``.
"""

import sys
from typing import Any

from foresight.core import __version__

__all__ = ["__version__", "evaluate", "simulate"]

if "gymnasium" in sys.modules:  # registers foresight/CrowdNav-v0; not imported otherwise (it is optional)
    import foresight.core.gym  # noqa: F401


def __dir__() -> list[str]:
    """What notebook completion offers: the lazily loaded ``evaluate`` and ``simulate`` too."""
    return sorted({*globals(), *__all__})


def __getattr__(name: str) -> Any:
    """``evaluate`` and ``simulate`` load the evaluation stack on first use, not with every ``foresight.*`` import."""
    if name in ("evaluate", "simulate"):
        from foresight import library

        return getattr(library, name)
    raise AttributeError(f"module 'foresight' has no attribute {name!r}")
