"""The seed runbook as one pipeline: config (:mod:`core.jobs.pipeline.config`), the graph and its runner
(:mod:`core.jobs.pipeline.runbook`), in-process children (:mod:`core.jobs.pipeline.local`) and seed mining
(:mod:`core.jobs.pipeline.seeds`)."""
