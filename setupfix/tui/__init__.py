"""The operator's terminal UI (Textual): corrections, their verdict, thermal drift, history.

The only package that imports :mod:`textual`.  Every number it shows comes from
:mod:`setupfix.pipeline` (the same functions as the CLI and batch); widgets lay out
the rows of :mod:`setupfix.pipeline.view` and :mod:`setupfix.pipeline.analysis_view` and
compute nothing.
"""

from __future__ import annotations

from setupfix.tui.app import SetupfixApp

__all__ = ["SetupfixApp"]
