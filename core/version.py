"""Code version stamped on every artifact: package version plus the git commit when available."""

from __future__ import annotations

import functools
import subprocess
from pathlib import Path

from foresight.core import __version__


@functools.cache
def code_version() -> str:
    root = Path(__file__).resolve().parent.parent
    try:
        sha = subprocess.run(
            ["git", "rev-parse", "--short=12", "HEAD"], cwd=root, capture_output=True, text=True, timeout=5
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        sha = ""
    return f"{__version__}+{sha}" if sha else __version__
