"""Text from reports and models shown as it is: never read as Textual/Rich markup.

Names come from reports and models (a dimension ``D1 [/b]``, a file ``cycle[1].csv``): a
``DataTable`` reads a plain ``str`` cell as markup, so such a name is mis-drawn or raises a
markup error in the middle of the operator's screen.  Every cell of a table of the screen is a
:class:`~rich.text.Text` (the tables that lay out rows wrap each name with :func:`plain`; the others
are a :class:`PlainTable`), and every other string from outside goes through :func:`plain` before a
widget gets it.
"""

from __future__ import annotations

from typing import Any

from rich.text import Text
from textual.widgets import DataTable

__all__ = ["PlainTable", "plain"]


def plain(text: str | Text) -> Text:
    """``text`` as literal text (a :class:`~rich.text.Text` is kept as it is)."""
    return text if isinstance(text, Text) else Text(text)


class PlainTable(DataTable[Text]):
    """A ``DataTable`` whose ``str`` cells are literal text, not markup."""

    def add_row(self, *cells: Any, **kwargs: Any) -> Any:
        return super().add_row(*(plain(c) if isinstance(c, str) else c for c in cells), **kwargs)
