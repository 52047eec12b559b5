"""Artifacts are written through a temporary and a rename: a write that fails midway leaves the final name as it
was (absent, or the previous complete file) and no temporary behind.

The fault is real, not mocked: each writer runs in a child process whose file-size limit (RLIMIT_FSIZE, with
SIGXFSZ ignored) makes the kernel fail a ``write`` partway through the file with EFBIG, as a full disk would with
ENOSPC (torch reports it as a RuntimeError).
"""

from __future__ import annotations

import errno
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from foresight.core import files

PRELUDE = """
import resource, signal, sys
from pathlib import Path
out = Path(sys.argv[1])

def limit(nbytes):
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (nbytes, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))
    print("limited", flush=True)
"""

#: name -> (final file, code that writes it under a limit smaller than the file)
WRITERS = {
    "collect dataset (npz)": (
        "base/dataset.npz",
        """
        from foresight.core.training.collect import CollectConfig, run_collect
        from foresight.core.runtime.context import StageContext
        from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
        config = CollectConfig(scenarios=["crossing_high"], seeds_per_scenario=2, max_steps=60, check_quality=False)
        limit(4096)
        run_collect(config, StageContext(workdir=out / "base", resolve_bundle=lambda ident: BUILTIN_CONFIG_ROOT))
    """,
    ),
    "checkpoint (torch)": (
        "model.pt",
        """
        import torch
        from foresight.core.predict.nn.checkpoint import save_checkpoint
        payload = {"format": "x", "model": {"w": torch.arange(200_000, dtype=torch.float32)}}
        limit(64 * 1024)
        save_checkpoint(payload, out / "model.pt")
    """,
    ),
    "trace (npz)": (
        "trace.npz",
        """
        from foresight.core.scenarios.loader import load_matrix
        from foresight.core.sim.simulator import Simulator
        from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
        sim = Simulator()
        matrix = load_matrix(BUILTIN_CONFIG_ROOT / "scenarios" / "classic_interactions.yaml")
        sim.reset(matrix.get("crossing_high"), 0)
        for _ in range(40):
            sim.step((0.5, 0.0))
        limit(2048)
        sim.trace.save(out / "trace.npz")
    """,
    ),
    "report (markdown)": (
        "report.md",
        """
        from foresight.core.reports.document import Document
        doc = Document("a report")
        doc.text("x" * 100_000)
        limit(8192)
        doc.write(out)
    """,
    ),
}


@pytest.mark.parametrize("name", sorted(WRITERS))
def test_a_write_failing_midway_leaves_no_half_file(tmp_path: Path, name: str) -> None:
    final, code = WRITERS[name]
    target = tmp_path / final
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_bytes(b"previous complete file")
    script = PRELUDE + textwrap.dedent(code) + "print('wrote')\n"
    proc = subprocess.run(
        [sys.executable, "-c", script, str(tmp_path)], capture_output=True, text=True, timeout=120
    )
    assert proc.stdout.split() == ["limited"] and proc.returncode != 0, proc.stderr[
        -2000:
    ]  # failed in the write
    assert target.read_bytes() == b"previous complete file"
    assert [p.name for p in tmp_path.rglob("*.tmp")] == []


def test_a_failing_writer_removes_its_temporary_and_keeps_the_old_file(tmp_path: Path) -> None:
    target = files.write_text(tmp_path / "a.json", "old")
    with pytest.raises(OSError, match="disk full"), files.replacing(target) as tmp:
        tmp.write_text("half")
        raise OSError(errno.ENOSPC, "disk full")
    assert target.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]
    files.write_bytes(target, b"new", fsync=True)
    assert target.read_bytes() == b"new" and sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]
