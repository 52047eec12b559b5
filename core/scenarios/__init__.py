"""Scenario matrices: config models (``model``), the matrix loader (``loader``) and seed manifests (``seeds``)."""
