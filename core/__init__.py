"""Foresight core: a pure library (simulation, maps, scenarios, prediction, planning, evaluation).

No web framework and no database here; the API and the worker are thin layers over it.
"""

__version__ = "0.1.0"
