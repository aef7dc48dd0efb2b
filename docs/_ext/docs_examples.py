"""Run every command example of the documentation during the Sphinx build, and fail the build on a drift.

The checker is ``tests/docs_console.py`` (the suite's too, so both read the pages alike): every
``console`` block of ``README.md`` and ``docs/`` is run in a scratch folder of its own and its output
compared with the page, every other block that shows commands must be marked
``<!-- not run: REASON -->``, and every inline command must name options the parser has. Each page
runs once per build, before Sphinx reads the sources; each failure is a warning naming the page and
line, and the build ends with status 1, ``-W`` or not.

``SETUPFIX_DOCS_EXAMPLES=skip`` leaves the examples out of a build whose caller runs them itself (the
suite's site-build test, whose examples run in ``tests/docs/test_console_examples.py``).
"""

from __future__ import annotations

import importlib.util
import os
import sys
import tempfile
from pathlib import Path
from types import ModuleType
from typing import Any

from sphinx.application import Sphinx
from sphinx.util import logging

CHECKER = Path(__file__).resolve().parents[2] / "tests" / "docs_console.py"
logger = logging.getLogger(__name__)


def checker() -> ModuleType:
    """``tests/docs_console.py``, loaded by path (the tests folder is no package)."""
    spec = importlib.util.spec_from_file_location("docs_console", CHECKER)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("docs_console", module)
    spec.loader.exec_module(module)
    return module


def check(app: Sphinx) -> None:
    """Run the examples once; log each failure, then stop the build if there was any."""
    if os.environ.get("SETUPFIX_DOCS_EXAMPLES", "") == "skip":
        logger.info("docs examples: not run (SETUPFIX_DOCS_EXAMPLES=skip)")
        return
    console = checker()
    every = [Path(p) for p in app.config.docs_examples_pages or console.PAGES]
    failures: list[str] = list(console.static_problems(every))
    pages = console.with_examples(every)
    with tempfile.TemporaryDirectory(prefix="setupfix-docs-examples-") as tmp:
        outcomes = console.run_pages(pages, Path(tmp))
    for page in pages:
        failures += outcomes[page]
    for failure in failures:
        logger.warning("documented example: %s", failure, type="setupfix", subtype="example")
    if failures:
        # the build goes on (every other warning is still reported) and ends with status 1, -W or not
        app.statuscode = 1
        logger.error("docs examples: %d example(s) drifted or unchecked (above)", len(failures))
    else:
        logger.info("docs examples: %d page(s) run, every output as shown", len(pages))


def setup(app: Sphinx) -> dict[str, Any]:
    # the pages to check: README.md and every page under docs/ unless a (test) project names others
    app.add_config_value("docs_examples_pages", None, "env")
    app.connect("builder-inited", check)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
