"""The recommendation: one row per register, what to change and the rules that changed it."""

from __future__ import annotations

from collections.abc import Sequence

from rich.text import Text
from textual.widgets import DataTable

from setupfix.pipeline.view import RegisterRow, signed

__all__ = ["RegisterTable"]


class RegisterTable(DataTable[Text | str]):
    """Register, model ID, delta, current and new value, flags and safety rules."""

    def on_mount(self) -> None:
        self.cursor_type = "row"

    def show(self, rows: Sequence[RegisterRow], *, digits: int = 3) -> None:
        self.clear(columns=True)
        for label, key in (("reg", "register"), ("id", "id"), ("offset", "offset"), ("Δ", "delta"),
                           ("current", "current"), ("new", "new"), ("", "flags"), ("rules", "rules")):
            self.add_column(label, key=key)
        for r in rows:
            moved = r.delta != 0.0
            self.add_row(
                Text(r.register, style="bold" if moved else "dim"), r.id, r.offset,
                Text(signed(r.delta, digits), style="bold" if moved else "dim", justify="right"),
                Text(signed(r.current, digits), justify="right"), Text(signed(r.new, digits), justify="right"),
                Text(r.flags, style="bold yellow" if r.at_limit else "dim"), "; ".join(r.rules), key=r.id)
