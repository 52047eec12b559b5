"""The seed runbook as one pipeline: config (:mod:`core.pipeline.config`), the graph and its runner
(:mod:`core.pipeline.runbook`), in-process children (:mod:`core.pipeline.local`) and seed mining
(:mod:`core.pipeline.seeds`)."""
