"""The hostile-input probe's inputs through the core readers: how fast each is refused and what it costs.

Prints one JSON object: per case the outcome (the error's first 100 characters) and the CPU seconds it took,
and a ``summary``: inputs tried, handled (refused with a clear error within 2 s of CPU, or a valid input read),
and the corrupted archives (``tests.archives.mangled``) that neither read nor failed with a ConfigError.
Memory is bounded by the readers' limits (archives: 50 MiB of content; tests/unit/limits assert the RSS).
Run: ``.venv/bin/python bench/hostile_inputs.py``.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # tests.archives: the archive generator

from foresight.core.archive import read_archive  # noqa: E402
from foresight.core.errors import ConfigError  # noqa: E402
from foresight.core.limits import check_nesting  # noqa: E402
from foresight.core.maps.svg import parse_svg_text  # noqa: E402
from foresight.core.yamlio import load_yaml  # noqa: E402
from tests.archives import hostile, mangled  # noqa: E402


def alias_bomb(levels: int) -> str:
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, levels + 1)]
    return "\n".join(lines) + "\n"


def deep_json(depth: int) -> object:
    value: object = {}
    for _ in range(depth):
        value = {"k": value}
    return value


def measure(fn) -> dict:  # noqa: ANN001
    t0 = time.process_time()
    try:
        fn()
        outcome = "accepted"
    except Exception as exc:  # noqa: BLE001 - the outcome is what we report
        outcome = f"{type(exc).__name__}: {exc}"[:100]
    return {"outcome": outcome, "cpu_s": round(time.process_time() - t0, 4)}


def main() -> None:
    cases = {
        "yaml alias bomb, 7 levels (271 bytes in the probe)": lambda: load_yaml(alias_bomb(7), "bomb.yaml"),
        "yaml alias bomb, 10 levels": lambda: load_yaml(alias_bomb(10), "bomb.yaml"),
        "yaml nested 20,000 deep": lambda: load_yaml("a: " + "[" * 20_000 + "]" * 20_000, "deep.yaml"),
        "svg with 100,000 nested <g>": lambda: parse_svg_text(
            '<svg xmlns="http://www.w3.org/2000/svg" width="9" height="9">'
            + "<g>" * 100_000
            + "</g>" * 100_000
            + "</svg>",
            name="deep",
            source="deep.svg",
        ),
        "json spec nested 100,000 deep": lambda: check_nesting(deep_json(100_000), source="body"),
    }
    for name, (data, _, _) in hostile().items():
        cases[f"archive: {name} ({len(data)} bytes)"] = lambda d=data: read_archive(
            d, max_bytes=50 << 20, max_files=2000
        )
    out = {name: measure(fn) for name, fn in cases.items()}
    unclear = []
    for i, data in enumerate(mangled(seed=7, count=200)):
        try:
            read_archive(data, max_bytes=50 << 20, max_files=2000)
        except ConfigError:
            continue
        except Exception as exc:  # noqa: BLE001 - what is reported
            unclear.append(f"{i}: {type(exc).__name__}: {exc}"[:100])
    handled = sum(r["outcome"] != "accepted" and r["cpu_s"] < 2 for r in out.values())
    out["summary"] = {
        "hostile_inputs_tried": len(cases),
        "hostile_inputs_refused_within_2s": handled,
        "corrupted_archives_tried": 200,
        "corrupted_archives_without_a_clear_error": unclear,
    }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
