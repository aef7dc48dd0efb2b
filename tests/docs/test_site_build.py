"""The documentation site builds with warnings as errors (when Sphinx is installed: the docs extra)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_site_builds_with_warnings_as_errors(tmp_path: Path) -> None:
    pytest.importorskip("sphinx")
    pytest.importorskip("myst_parser")
    pytest.importorskip("furo")
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "sphinx",
            "-W",
            "--keep-going",
            "-q",
            "-b",
            "html",
            str(ROOT / "docs"),
            str(tmp_path / "html"),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    html = (tmp_path / "html" / "reference" / "cli.html").read_text(encoding="utf-8")
    assert "--program-number" in html and "setupfix history migrate" in html
    assert "<p>`" not in html, "a table cell split inside code (an unescaped | ?)"
    assert "PATH|URL</span>" in html
