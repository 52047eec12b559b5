"""A finished stage's quality verdict: its gates passed, a gate failed, or the integrity checks failed. One
vocabulary for the job table (``core.jobs.results.verdict`` decides it), the API's job rows, the dashboard's badges
and the CLI's exit codes (2 for a failed verdict)."""

from __future__ import annotations

from typing import Literal

Verdict = Literal["passed", "failed_gate", "failed_integrity"]
