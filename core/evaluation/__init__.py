"""Evaluation engine: metrics, failure taxonomy, aggregates, the parallel runner, diagnostics, campaigns, gates.

Stage entry points (each ``run_<stage>(config, ctx) -> result``):
``runner.run_evaluation``, ``diagnostics.run_diagnostics``, ``campaign.run_campaign``.
Definitions follow the shared metrics-and-taxonomy.md.
"""
