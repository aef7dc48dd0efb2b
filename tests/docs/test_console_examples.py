"""Every console example of the README and the documentation runs, and prints what the page shows.

The pages run at once (each in its own scratch folder, its steps in order): the examples are
sub-processes, so threads overlap their start-up and keep the whole under the suite's budget.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from docs_console import PAGES, ROOT, matches, run, scratch, steps

_WITH_EXAMPLES = [p for p in PAGES if any(s.command for s in steps(p))]


def _name(page: Path) -> str:
    return page.relative_to(ROOT).as_posix() if page.is_relative_to(ROOT) else str(page)


def _run_page(page: Path, folder: Path) -> list[str]:
    """Run one page's steps; the failures, each with the page line, the command and both texts."""
    cwd = scratch(folder)
    failures = []
    for step in steps(page):
        if step.command is None:
            assert step.file is not None
            (cwd / step.file).write_text(step.text, encoding="utf-8")
            continue
        actual = run(step.command, cwd)
        if not matches(step.text, actual):
            failures.append(
                f"{_name(page)}:{step.line}: $ {step.command}\n--- expected\n{step.text}\n--- got\n{actual}"
            )
    return failures


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory: pytest.TempPathFactory) -> dict[Path, list[str]]:
    base = tmp_path_factory.mktemp("docs-examples")
    with ThreadPoolExecutor(max_workers=4) as pool:
        futures = {page: pool.submit(_run_page, page, base / f"page{i}") for i, page in enumerate(_WITH_EXAMPLES)}
        return {page: future.result() for page, future in futures.items()}


def test_the_pages_hold_examples() -> None:
    """The README and the tutorials are tested, not skipped by a parser that finds nothing."""
    names = {p.relative_to(ROOT).as_posix() for p in _WITH_EXAMPLES}
    assert {
        "README.md",
        "docs/tutorials/first-correction.md",
        "docs/tutorials/own-report.md",
        "docs/tutorials/multi-station.md",
        "docs/tutorials/closing-the-loop.md",
    } <= names


def test_the_matcher_is_strict() -> None:
    assert matches("a … c\n...\nz", "a bb c\nx\ny\nz\n")
    assert not matches("a … c", "a bb d\n")
    assert not matches("one", "one\ntwo\n")
    assert matches("", "")


def test_a_stale_example_fails(tmp_path: Path) -> None:
    """An example whose output changed is reported (the check is not vacuous)."""
    page = tmp_path / "page.md"
    page.write_text("```console\n$ echo 1.000\n0.999\n```\n", encoding="utf-8")
    assert steps(page)[0].command == "echo 1.000"
    assert _run_page(page, tmp_path / "run")


@pytest.mark.slow
@pytest.mark.parametrize("page", _WITH_EXAMPLES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_console_examples(page: Path, outcomes: dict[Path, list[str]]) -> None:
    failures = outcomes[page]
    assert not failures, "\n\n".join(failures)
