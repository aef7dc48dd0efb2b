"""The operator's terminal UI (Textual): corrections, their verdict, thermal drift, history.

The only package that imports :mod:`textual`.  Every number it shows comes from
:mod:`setupfix.usecases` (the same functions as the CLI and batch); widgets lay out
the rows of :mod:`setupfix.views.correction` and :mod:`setupfix.views.analysis` and
compute nothing.
"""

from __future__ import annotations

from setupfix.tui.app import SetupfixApp

__all__ = ["SetupfixApp"]
