"""The recommendation: one row per register (component), what to change and the rules that changed it."""

from __future__ import annotations

from collections.abc import Sequence

from rich.text import Text
from textual.widgets import DataTable

from setupfix.tui.widgets.plain import plain
from setupfix.views.correction import RegisterRow, signed

__all__ = ["RegisterTable", "DEGREES"]

#: The unit of a WKS rotation component (``W1.C``): the model's rotation is in degrees.
DEGREES = "°"


class RegisterTable(DataTable[Text]):
    """Controller register, model ID (a component ``W1.X`` / ``W1.C`` / ``T5.R`` in a multi-axis model),
    wear/geometry, delta, current and new value, unit, flags and safety rules.

    Column widths are set up front, as in :class:`DimensionTable`.
    """

    def on_mount(self) -> None:
        self.cursor_type = "row"

    def show(self, rows: Sequence[RegisterRow], *, unit: str, digits: int = 3, rotation_digits: int = 4) -> None:
        """``unit`` is the model's length unit; a rotation component (``C``) is in degrees, shown with
        ``rotation_digits`` decimals (its own grid)."""
        self.clear(columns=True)
        cells = []
        for r in rows:
            rotation = r.component == "C"
            d = rotation_digits if rotation else digits
            cells.append(
                [
                    r.register,
                    r.id,
                    r.offset,
                    signed(r.delta, d),
                    signed(r.current, d),
                    signed(r.new, d),
                    DEGREES if rotation else unit,
                    r.flags,
                    "; ".join(r.rules),
                ]
            )
        for i, (label, key) in enumerate(
            (
                ("reg", "register"),
                ("id", "id"),
                ("offset", "offset"),
                ("Δ", "delta"),
                ("current", "current"),
                ("new", "new"),
                ("unit", "unit"),
                ("", "flags"),
                ("rules", "rules"),
            )
        ):
            self.add_column(label, key=key, width=max([len(label), *(len(c[i]) for c in cells)]))
        for r, c in zip(rows, cells, strict=True):
            moved = r.delta != 0.0
            self.add_row(
                Text(c[0], style="bold" if moved else "dim"),
                plain(c[1]),
                plain(c[2]),
                Text(c[3], style="bold" if moved else "dim", justify="right"),
                Text(c[4], justify="right"),
                Text(c[5], justify="right"),
                plain(c[6]),
                Text(c[7], style="bold yellow" if r.at_limit else "dim"),
                plain(c[8]),
                key=r.id,
            )
