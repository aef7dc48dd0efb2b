"""The documentation site builds with warnings as errors (when Sphinx is installed: the docs extra), sets
no option with an en dash, and fails when a documented example drifts."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from setupfix.cli import build_parser

ROOT = Path(__file__).resolve().parents[2]


def _sphinx(source: Path, out: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    pytest.importorskip("sphinx")
    pytest.importorskip("myst_parser")
    pytest.importorskip("furo")
    return subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", str(source), str(out)],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, **(env or {})},
    )


def _long_options() -> set[str]:
    found: set[str] = set()
    pending = [build_parser()]
    while pending:
        parser = pending.pop()
        for action in parser._actions:
            found.update(o for o in action.option_strings if o.startswith("--"))
            if action.choices and isinstance(action.choices, dict):
                pending.extend(p for p in action.choices.values() if hasattr(p, "_actions"))
    return found


def en_dashed_options(html: str, options: set[str]) -> list[str]:
    """The options of the parser written with an en dash (``–current``) in a page's text."""
    names = {o[2:] for o in options}
    return sorted({m.group(0) for m in re.finditer(r"(?<![\w-])–([a-z][a-z0-9-]*)", html) if m.group(1) in names})


def test_an_en_dashed_option_is_found() -> None:
    """The check reads a link text and a help text as the build wrote them before the fix."""
    html = (
        '<span class="std std-doc">Controllers and –current</span> temperature log for –thermal; '
        "max–min and 5.79–9.11 are ranges"
    )
    assert en_dashed_options(html, _long_options()) == ["–current", "–thermal"]


@pytest.mark.slow
def test_site_builds_with_warnings_as_errors(tmp_path: Path) -> None:
    # the examples run in tests/docs/test_console_examples.py: not a second time here
    done = _sphinx(ROOT / "docs", tmp_path / "html", {"SETUPFIX_DOCS_EXAMPLES": "skip"})
    assert done.returncode == 0, done.stderr
    html = (tmp_path / "html" / "reference" / "cli.html").read_text(encoding="utf-8")
    assert "--program-number" in html and "setupfix history migrate" in html
    assert "<p>`" not in html, "a table cell split inside code (an unescaped | ?)"
    assert "PATH|URL</span>" in html
    options = _long_options()
    dashed = {
        page.relative_to(tmp_path / "html").as_posix(): en_dashed_options(page.read_text(encoding="utf-8"), options)
        for page in (tmp_path / "html").rglob("*.html")
    }
    assert {page: found for page, found in dashed.items() if found} == {}
    tutorial = (tmp_path / "html" / "tutorials" / "first-correction.html").read_text(encoding="utf-8")
    assert "Controllers and <code" in tutorial or "Controllers and --current" in tutorial


@pytest.mark.slow
def test_a_drifting_example_fails_the_build(tmp_path: Path) -> None:
    """The docs build runs the checker: a page whose shown output is stale, or whose command block is
    neither run nor marked, stops the build with the page and line named."""
    source = tmp_path / "src"
    source.mkdir()
    (source / "conf.py").write_text(
        "import sys\n"
        f"sys.path.insert(0, {str(ROOT / 'docs' / '_ext')!r})\n"
        f"sys.path.insert(0, {str(ROOT)!r})\n"
        'extensions = ["myst_parser", "docs_examples"]\n'
        f"docs_examples_pages = [{str(source / 'index.md')!r}]\n",
        encoding="utf-8",
    )
    (source / "index.md").write_text(
        "# A page\n\n```console\n$ echo 0.072\n0.071\n```\n\n```bash\nsetupfix formats\n```\n", encoding="utf-8"
    )
    done = _sphinx(source, tmp_path / "html", {"SETUPFIX_DOCS_EXAMPLES": "run"})  # even under .ci/run
    assert done.returncode != 0
    assert "index.md:4: $ echo 0.072" in done.stderr and "index.md:8: a ```bash block" in done.stderr
    (source / "index.md").write_text(
        "# A page\n\n```console\n$ echo 0.072\n0.072\n```\n\n"
        "<!-- not run: a synopsis -->\n```bash\nsetupfix formats\n```\n",
        encoding="utf-8",
    )
    done = _sphinx(source, tmp_path / "html2", {"SETUPFIX_DOCS_EXAMPLES": "run"})
    assert done.returncode == 0, done.stderr
