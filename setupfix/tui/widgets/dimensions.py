"""The dimension table: deviation, limits and the tolerance zone before and after."""

from __future__ import annotations

from collections.abc import Sequence

from rich.text import Text
from textual.widgets import DataTable

from setupfix.pipeline.view import DimensionRow, limits_text, signed

__all__ = ["DimensionTable"]


class DimensionTable(DataTable[Text | str]):
    """One row per measured dimension; click a header (or press s) to sort."""

    def on_mount(self) -> None:
        self.cursor_type = "row"
        self.zebra_stripes = True

    def show(self, rows: Sequence[DimensionRow], *, wide: bool) -> None:
        """Replace the rows (``wide`` adds the margins before and after)."""
        self.clear(columns=True)
        # Fixed widths where the content is symbols: the layout does not wait on measuring them.
        self.add_column("st", key="flags", width=4)
        self.add_column("name", key="name")
        self.add_column("stn", key="station")
        self.add_column("dev", key="deviation")
        self.add_column("limits", key="limits")
        self.add_column("before", key="bar_before", width=11)
        self.add_column("pred", key="predicted")
        self.add_column("after", key="bar_after", width=11)
        if wide:
            self.add_column("margin₀", key="margin_before")
            self.add_column("margin₁", key="margin_after")
        for r in rows:
            before, after = r.bars(11)
            style = "" if r.in_before else "red"
            after_style = "bold red" if not r.in_after else ("bold" if r.binding else "")
            cells: list[Text | str] = [
                Text(r.flags, style=after_style), r.name, r.station,
                Text(signed(r.deviation), style=style, justify="right"), limits_text(r.lower, r.upper),
                Text(before, style=style), Text(signed(r.predicted), style=after_style, justify="right"),
                Text(after, style=after_style)]
            if wide:
                cells += [Text(signed(r.margin_before), justify="right"), Text(signed(r.margin_after), justify="right")]
            self.add_row(*cells, key=r.id)
