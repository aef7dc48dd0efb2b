"""Regenerate the closed-loop sample: 40 cycles of the guide pins with an undeclared thermal drift.

    python sample_reports/closed_loop/generate.py

Same as ``setupfix simulate --model sample_reports/guide_pins/model.toml --out
sample_reports/closed_loop --seed 2026 --effect kind=thermal,channel=spindle,magnitude=0.003``.
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]


def main() -> None:
    sys.path.insert(0, str(ROOT))
    from setupfix.cli import main as cli

    code = cli(
        [
            "simulate",
            "--model",
            str(ROOT / "sample_reports" / "guide_pins" / "model.toml"),
            "--out",
            str(HERE),
            "--seed",
            "2026",
            "--effect",
            "kind=thermal,channel=spindle,magnitude=0.003",
        ]
    )
    raise SystemExit(code)


if __name__ == "__main__":
    main()
