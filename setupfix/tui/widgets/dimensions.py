"""The dimension table: deviation, limits and the tolerance zone before and after."""

from __future__ import annotations

from collections.abc import Sequence

from rich.text import Text
from textual.widgets import DataTable

from setupfix.tui.widgets.plain import plain
from setupfix.views.correction import DimensionRow, limits_text, signed

__all__ = ["DimensionTable"]

#: Width of a tolerance-zone bar [characters].
BAR = 11


def _width(values: Sequence[str], header: str) -> int:
    return max([len(header), *(len(v) for v in values)])


class DimensionTable(DataTable[Text]):
    """One row per measured dimension; click a header (or press s) to sort.

    Every column gets its width up front: measured lazily, the widths would change
    after the first paint (and a screenshot could catch either).
    """

    def on_mount(self) -> None:
        self.cursor_type = "row"
        self.zebra_stripes = True

    def show(self, rows: Sequence[DimensionRow], *, wide: bool) -> None:
        """Replace the rows (``wide`` adds the margins before and after)."""
        self.clear(columns=True)
        limits = [limits_text(r.lower, r.upper) for r in rows]
        self.add_column("st", key="flags", width=4)
        self.add_column("name", key="name", width=_width([r.name for r in rows], "name"))
        self.add_column("stn", key="station", width=_width([r.station for r in rows], "stn"))
        self.add_column("dev", key="deviation", width=8)
        self.add_column("limits", key="limits", width=_width(limits, "limits"))
        self.add_column("before", key="bar_before", width=BAR)
        self.add_column("pred", key="predicted", width=8)
        self.add_column("after", key="bar_after", width=BAR)
        if wide:
            self.add_column("margin₀", key="margin_before", width=8)
            self.add_column("margin₁", key="margin_after", width=8)
        zones = wide and any(r.zone is not None for r in rows)  # a position as a CMM prints it (⌀)
        if zones:
            self.add_column("position ⌀", key="position", width=_width([r.position_text for r in rows], "position ⌀"))
        for r, lim in zip(rows, limits, strict=True):
            before, after = r.bars(BAR)
            style = "" if r.in_before else "red"
            after_style = "bold red" if not r.in_after else ("bold" if r.binding else "")
            cells = [
                Text(r.flags, style=after_style),
                plain(r.name),
                plain(r.station),
                Text(signed(r.deviation), style=style, justify="right"),
                plain(lim),
                Text(before, style=style),
                Text(signed(r.predicted), style=after_style, justify="right"),
                Text(after, style=after_style),
            ]
            if wide:
                cells += [Text(signed(r.margin_before), justify="right"), Text(signed(r.margin_after), justify="right")]
            if zones:
                cells.append(plain(r.position_text))
            self.add_row(*cells, key=r.id)
