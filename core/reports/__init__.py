"""Reports of the pipeline stages: Markdown + self-contained HTML with PNG/GIF figures, from stage results.

Entry points (each writes under ``workdir`` and returns the written paths, pictures first):
``evaluation.write_evaluation_report``, ``diagnostics.write_diagnostics_report``,
``campaign.write_campaign_report``, ``training.write_training_report``,
``compare.write_comparison_report`` (A/B of two evaluations) and ``pipeline.write_pipeline_report``;
``stage.write_stage_report(kind, result, workdir)`` picks the writer by job kind.
"""
