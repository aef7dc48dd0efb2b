"""The correction tab on screen: the current state pushed into its widgets, narrow or wide, short or tall."""

from __future__ import annotations

from textual import events, on
from textual.markup import escape
from textual.widgets import DataTable

from setupfix.correction.offsets import grid_decimals
from setupfix.tui.state import AppState
from setupfix.tui.widgets import DimensionTable, RegisterTable, SummaryBar, ThermalPanel
from setupfix.views import correction as view

__all__ = ["CorrectionDisplay", "WIDE", "TALL"]


#: Columns from which the recommendation sits beside the dimensions and margins are shown.
WIDE = 120
#: Lines below which the screen is short: a compact summary, the dimensions out of tolerance first.
TALL = 30


class CorrectionDisplay(AppState):
    """Shows the cycle on screen in the correction tab and re-lays it out on a resize."""

    def _show(self) -> None:
        """Push the current state down into the correction tab's widgets."""
        c = self._current()
        summary = self.query_one(SummaryBar)
        if c is None:
            reason = self.problem or (
                f"✗ {self.opened.problem} (tab 5 shows the match table)" if self.opened and self.opened.problem else ""
            )
            summary.show(None, optimizer=self.optimizer, problem=reason)
            self.query_one(DimensionTable).clear(columns=True)
            self.query_one(RegisterTable).clear(columns=True)
            return
        n = len(self.opened.corrections) if self.opened else 1
        part = f"part {c.part.part or '—'}" + (f" ({self.part_index + 1}/{n}, [ ] to change)" if n > 1 else "")
        head = view.summary(c)
        reader = tuple(f"⚠ {n}" for n in self.opened.notes) if self.opened else ()
        current = f"⚠ {self.current_problem}; exports are changes (add)" if self.current_problem else ""
        summary.show(
            head,
            optimizer=self.optimizer,
            part=part,
            problem="\n".join(t for t in (current, self.problem, c.thermal.line() if c.thermal else "", *reader) if t),
        )
        if self.inputs.thermal is not None and self.inputs.temperatures is not None:
            self.query_one(ThermalPanel).feed_forward(
                self._feed_text() or f"no feed-forward for {c.part.report} {c.part.part}".rstrip()
            )
        rows = view.filter_rows(view.dimension_rows(c), self.station)
        small = self._short or not self._wide
        out = [r for r in rows if not (r.in_before and r.in_after)]
        if self.sort_key is not None:
            rows = view.sort_rows(rows, self.sort_key)
        elif small:  # a small screen shows what needs the operator first: out of tolerance, before or after
            rows = out + [r for r in rows if r.in_before and r.in_after]
        dims = self.query_one(DimensionTable)
        dims.show(rows, wide=self._wide)
        order = self.sort_key or ("out of tolerance first" if small else "model")
        dims.border_title = escape(f"dimensions · station {self.station or 'all'} · sort {order}")
        # short and narrow: the table holds the dimensions out of tolerance (at least 2 rows; with its border,
        # header and scroll bar), the registers the rest
        dims.styles.height = 3 + max(2, len(out)) if self._short and not self._wide else None
        m = c.model
        self.query_one(RegisterTable).show(
            view.register_rows(c, self.opened.current if self.opened else None),
            unit=m.unit,
            digits=grid_decimals(m.resolution),
            rotation_digits=grid_decimals(m.rotation_resolution),
        )
        where = f"axes {' '.join(m.axes)}" if m.multi_axis else f"axis {m.axis}"
        self.query_one(RegisterTable).border_title = escape(
            f"recommendation [{m.unit}, {where}]" + (" · --current does not fit: changes only" if current else "")
        )

    def on_resize(self, event: events.Resize) -> None:
        # Rebuild the tables only when the layout changes between narrow and wide, short and tall.
        wide, short = event.size.width >= WIDE, event.size.height < TALL
        if (wide, short) != (self._wide, self._short):
            self._wide, self._short = wide, short
            self._show()

    @on(DataTable.HeaderSelected, "#dimensions")
    def _header(self, event: DataTable.HeaderSelected) -> None:
        key = str(event.column_key.value)
        if key in view.SORT_KEYS:
            self.sort_key = None if self.sort_key == key else key
            self._show()
