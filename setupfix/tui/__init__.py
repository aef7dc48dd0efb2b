"""The operator's terminal UI (Textual): corrections, their verdict, thermal drift, history.

The only package that imports :mod:`textual`.  Every number it shows comes from
:mod:`setupfix.usecases` (the same functions as the CLI and batch); widgets lay out
the rows of :mod:`setupfix.views.correction` and :mod:`setupfix.views.analysis` and
compute nothing.

:class:`SetupfixApp` is imported when it is first asked for: the operator-session use case
(:mod:`setupfix.tui.session`) and the session's state (:mod:`setupfix.tui.state`) load no Textual.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from setupfix.tui.app import SetupfixApp

__all__ = ["SetupfixApp"]


def __getattr__(name: str) -> object:
    if name == "SetupfixApp":
        from setupfix.tui.app import SetupfixApp

        return SetupfixApp
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
