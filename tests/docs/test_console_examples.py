"""Every console example of the README and the documentation runs, and prints what the page shows."""

from __future__ import annotations

from pathlib import Path

import pytest
from docs_console import PAGES, ROOT, matches, run, scratch, steps

_WITH_EXAMPLES = [p for p in PAGES if any(s.command for s in steps(p))]


def test_the_pages_hold_examples() -> None:
    """The README and the tutorials are tested, not skipped by a parser that finds nothing."""
    names = {p.relative_to(ROOT).as_posix() for p in _WITH_EXAMPLES}
    assert {"README.md", "docs/tutorials/first-correction.md", "docs/tutorials/own-report.md"} <= names


def test_the_matcher_is_strict() -> None:
    assert matches("a … c\n...\nz", "a bb c\nx\ny\nz\n")
    assert not matches("a … c", "a bb d\n")
    assert not matches("one", "one\ntwo\n")
    assert matches("", "")


@pytest.mark.parametrize("page", _WITH_EXAMPLES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_console_examples(page: Path, tmp_path: Path) -> None:
    cwd = scratch(tmp_path / "page")
    for step in steps(page):
        where = f"{page.relative_to(ROOT)}:{step.line}"
        if step.command is None:
            assert step.file is not None
            (cwd / step.file).write_text(step.text, encoding="utf-8")
            continue
        actual = run(step.command, cwd)
        assert matches(step.text, actual), f"{where}: $ {step.command}\n--- expected\n{step.text}\n--- got\n{actual}"
