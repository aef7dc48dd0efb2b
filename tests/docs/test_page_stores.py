"""Pages followed one after another in one folder do not share a history store: each page that writes
one names its own (the batch how-to and the plant how-to both wrote ``shop.db``, so the second page's
``history show`` listed the first page's machine too)."""

from __future__ import annotations

import os
import re
from collections import defaultdict
from pathlib import Path

import pytest
from docs_console import DOCS, PAGES, ROOT, blocks, run_page

_STORE = re.compile(r"--(?:db|store|from)[ =](?!postgresql:)(\S+)")


def store_names(page: Path) -> set[str]:
    """The store files the commands of one page name (run or not), URLs left out."""
    names: set[str] = set()
    for block in blocks(page):
        for line in block.body:
            names.update(m.group(1) for m in _STORE.finditer(line))
    return names


def shared_stores(pages: list[Path]) -> dict[str, list[str]]:
    """Store files named by more than one page: ``{"shop.db": ["a.md", "b.md"]}``."""
    owners: dict[str, list[str]] = defaultdict(list)
    for page in pages:
        for name in store_names(page):
            owners[name].append(page.relative_to(ROOT).as_posix() if page.is_relative_to(ROOT) else page.name)
    return {name: sorted(who) for name, who in owners.items() if len(who) > 1}


def test_each_store_belongs_to_one_page() -> None:
    assert shared_stores(PAGES) == {}


def test_a_shared_store_is_named(tmp_path: Path) -> None:
    """A variant of the collision: a synopsis (not run) and a run example naming one file, spelled two ways."""
    one, two = tmp_path / "one.md", tmp_path / "two.md"
    one.write_text("<!-- not run: a synopsis -->\n```bash\nsetupfix spc --db=plant.db --json\n```\n", encoding="utf-8")
    two.write_text(
        "```console\n$ setupfix correct --model m.toml --store plant.db r.csv | tail -n 1\nok\n"
        "$ setupfix history migrate --from plant.db --db postgresql://u@h/d\n```\n",
        encoding="utf-8",
    )
    assert shared_stores([one, two]) == {"plant.db": ["one.md", "two.md"]}
    assert store_names(two) == {"plant.db"}


@pytest.mark.slow
def test_the_batch_and_plant_pages_followed_in_one_folder(tmp_path: Path) -> None:
    """A reader who does the batch how-to, then the plant how-to, in one folder gets what each shows."""
    if os.environ.get("SETUPFIX_DOCS_EXAMPLES", "") == "skip":
        pytest.skip("SETUPFIX_DOCS_EXAMPLES=skip: the docs build runs the examples (.ci/run)")
    folder = tmp_path / "shop"
    assert run_page(DOCS / "howto" / "batch-and-history.md", folder) == []
    assert run_page(DOCS / "howto" / "plant-database.md", folder) == []
