"""Foresight: a service platform for predictive local planners in crowd navigation.

The repository's top-level folders install under this one namespace (see ``setup.py``):
``foresight.core`` (the pure library), ``foresight.api``, ``foresight.worker``, ``foresight.cli``, and the
run-time data the service needs: ``foresight.migrations``, ``foresight.configs``, ``foresight.model``.
"""

from foresight.core import __version__

__all__ = ["__version__"]
