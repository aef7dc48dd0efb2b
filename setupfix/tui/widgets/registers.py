"""The recommendation: one row per register, what to change and the rules that changed it."""

from __future__ import annotations

from collections.abc import Sequence

from rich.text import Text

from setupfix.tui.widgets.plain import PlainTable
from setupfix.pipeline.view import RegisterRow, signed

__all__ = ["RegisterTable"]


class RegisterTable(PlainTable):
    """Register, model ID, wear/geometry, delta, current and new value, flags and safety rules.

    Column widths are set up front, as in :class:`DimensionTable`.
    """

    def on_mount(self) -> None:
        self.cursor_type = "row"

    def show(self, rows: Sequence[RegisterRow], *, digits: int = 3) -> None:
        self.clear(columns=True)
        cells = [[r.register, r.id, r.offset, signed(r.delta, digits), signed(r.current, digits),
                  signed(r.new, digits), r.flags, "; ".join(r.rules)] for r in rows]
        for i, (label, key) in enumerate((("reg", "register"), ("id", "id"), ("offset", "offset"), ("Δ", "delta"),
                                          ("current", "current"), ("new", "new"), ("", "flags"),
                                          ("rules", "rules"))):
            self.add_column(label, key=key, width=max([len(label), *(len(c[i]) for c in cells)]))
        for r, c in zip(rows, cells, strict=True):
            moved = r.delta != 0.0
            self.add_row(
                Text(c[0], style="bold" if moved else "dim"), c[1], c[2],
                Text(c[3], style="bold" if moved else "dim", justify="right"),
                Text(c[4], justify="right"), Text(c[5], justify="right"),
                Text(c[6], style="bold yellow" if r.at_limit else "dim"), c[7], key=r.id)
