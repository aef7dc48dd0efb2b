"""Sphinx configuration of the setupfix documentation site (MyST Markdown, furo).

Build: ``python -m sphinx -W -b html docs OUT`` (the ``docs`` extra installs what it needs).
The reference pages of the commands and of the model keys are generated from the code at every build
by ``_ext/setupfix_reference.py``.
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
sys.path.insert(0, str(HERE.parent))  # the checked-out package wins over an installed copy

import setupfix  # noqa: E402

project = "setupfix"
author = "the setupfix authors"
copyright = "the setupfix authors, MIT licence"
release = version = setupfix.__version__

# docs_examples runs every command the pages show and compares its output (tests/docs_console.py)
extensions = ["myst_parser", "setupfix_reference", "docs_examples"]
source_suffix = {".md": "markdown"}
master_doc = "index"
exclude_patterns = ["_build", "README.md"]
myst_enable_extensions = ["dollarmath", "deflist", "colon_fence"]
myst_heading_anchors = 3
# Typography turns straight quotes into curly ones, never "--" into an en dash: "--" is an option's
# prefix here (``--current`` in a heading reused as a link text, ``--store`` in a help text), not a dash.
smartquotes_action = "qe"
html_theme = "furo"
html_title = f"setupfix {release}"
