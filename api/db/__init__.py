"""Database layer: table models, engine/session set-up, and the job-queue SQL."""
