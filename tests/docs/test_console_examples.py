"""Every command example of the README and the documentation runs and prints what the page shows;
every other command block says why it cannot run; every inline command names real options.

The pages run at once (each in its own scratch folder, its steps in order): the examples are
sub-processes, so threads overlap their start-up. The docs build runs the same checker
(``docs/_ext/docs_examples.py``); ``SETUPFIX_DOCS_EXAMPLES=skip`` leaves the runs to it (``.ci/run``),
so each page runs once in CI.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from docs_console import (
    PAGES,
    ROOT,
    matches,
    option_errors,
    run_page,
    run_pages,
    static_problems,
    steps,
    unmarked,
    with_examples,
)

from setupfix.cli import build_parser

_WITH_EXAMPLES = with_examples(PAGES)


def _rel(page: Path) -> str:
    return page.relative_to(ROOT).as_posix()


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory: pytest.TempPathFactory) -> dict[Path, list[str]]:
    if os.environ.get("SETUPFIX_DOCS_EXAMPLES", "") == "skip":
        pytest.skip("SETUPFIX_DOCS_EXAMPLES=skip: the docs build runs the examples (.ci/run)")
    return run_pages(_WITH_EXAMPLES, tmp_path_factory.mktemp("docs-examples"))


def test_the_pages_hold_examples() -> None:
    """The README, the tutorials and the how-tos are tested, not skipped by a parser that finds nothing."""
    names = {p.relative_to(ROOT).as_posix() for p in _WITH_EXAMPLES}
    assert {
        "README.md",
        "docs/tutorials/first-correction.md",
        "docs/tutorials/own-report.md",
        "docs/tutorials/multi-station.md",
        "docs/tutorials/closing-the-loop.md",
        "docs/howto/batch-and-history.md",
        "docs/howto/plant-database.md",
        "docs/howto/thermal.md",
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
    assert run_page(page, tmp_path / "run")


@pytest.mark.parametrize("page", PAGES, ids=_rel)
def test_every_command_block_is_run_or_marked(page: Path) -> None:
    """No page shows a command that is neither run nor marked not runnable (with its reason), nor an
    inline command with an option the parser lacks."""
    assert static_problems([page]) == []


@pytest.mark.parametrize(
    ("block", "line"),
    [
        ("```bash\nsetupfix history show --db plant.db\n```\n", 5),
        ("```sh\nsetupfix spc --db x.db\n```\n", 5),
        ("```text\n$ setupfix formats\ncanonical\n```\n", 5),
        ("```\n$ setupfix formats\n```\n", 5),
        ("<!-- not run: -->\n```bash\nsetupfix formats\n```\n", 6),
        ("- in a list:\n\n  ```bash\n  setupfix formats\n  ```\n", 7),
    ],
)
def test_an_unmarked_command_block_is_named(tmp_path: Path, block: str, line: int) -> None:
    page = tmp_path / "page.md"
    page.write_text("# A page\n\nSome text.\n\n" + block, encoding="utf-8")
    problems = unmarked(page)
    assert len(problems) == 1 and f"page.md:{line}:" in problems[0]


def test_an_indented_example_runs(tmp_path: Path) -> None:
    """A console block inside a list item is run like any other, its indentation removed."""
    page = tmp_path / "page.md"
    page.write_text("1. count:\n\n   ```console\n   $ echo 0.071\n   0.072\n   ```\n", encoding="utf-8")
    assert [s.command for s in steps(page)] == ["echo 0.071"]
    assert run_page(page, tmp_path / "run")


def test_a_marked_block_is_not_run(tmp_path: Path) -> None:
    """``<!-- not run: REASON -->`` keeps a block, even a console one, out of the runs."""
    page = tmp_path / "page.md"
    page.write_text(
        "<!-- not run: needs the plant's server -->\n```console\n$ false\nnever\n```\n"
        "<!-- not run: a synopsis -->\n```bash\nsetupfix batch --model MODEL DIR\n```\n",
        encoding="utf-8",
    )
    assert steps(page) == [] and unmarked(page) == []


@pytest.mark.parametrize(
    ("span", "missing"),
    [
        ("`diagnose --store shop.db`", "--store"),  # the plant how-to's slip: diagnose takes --db
        ("`setupfix spc --store plant.db --json`", "--store"),
        ("`setupfix history import --bd x.db`", "--bd"),
        ("`correct --offset fix.nc`", "--offset"),
    ],
)
def test_an_inline_command_with_an_unknown_option_is_named(tmp_path: Path, span: str, missing: str) -> None:
    page = tmp_path / "page.md"
    page.write_text(f"# A page\n\nthe history is read by {span} on each machine.\n", encoding="utf-8")
    problems = option_errors(page, build_parser())
    assert len(problems) == 1 and f"no option {missing}" in problems[0] and ":3:" in problems[0]


def test_inline_commands_with_real_options_pass(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text(
        "`diagnose --db shop.db`, `setupfix history export dfq --db STORE --out F.dfq`, "
        "`correct --thermal`, `setupfix --help`, `--store` alone, `batch` alone\n"
        "```bash\nsetupfix spc --store x\n```\n",
        encoding="utf-8",
    )
    assert option_errors(page, build_parser()) == []


@pytest.mark.slow
@pytest.mark.parametrize("page", _WITH_EXAMPLES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_console_examples(page: Path, outcomes: dict[Path, list[str]]) -> None:
    failures = outcomes[page]
    assert not failures, "\n\n".join(failures)
