"""The correction tab: the headline, the dimensions and the recommendation of the cycle on screen.

It lays out the session's state (:class:`~setupfix.tui.state.SessionState`) narrow or wide, short or tall,
and computes nothing; a click on a column header asks for a sort with :class:`CorrectionTab.SortChosen`.
"""

from __future__ import annotations

from textual import on
from textual.app import ComposeResult
from textual.containers import Horizontal
from textual.markup import escape
from textual.message import Message
from textual.widgets import DataTable, TabPane

from setupfix.correction.offsets import grid_decimals
from setupfix.tui.state import SessionState, attention_order
from setupfix.tui.widgets.dimensions import DimensionTable
from setupfix.tui.widgets.registers import RegisterTable
from setupfix.tui.widgets.summary import SummaryBar
from setupfix.views import correction as view

__all__ = ["CorrectionTab", "WIDE", "TALL"]


#: Columns from which the recommendation sits beside the dimensions and margins are shown.
WIDE = 120
#: Lines below which the screen is short: a compact summary, the dimensions that need the operator first.
TALL = 30


class CorrectionTab(TabPane):
    """The summary bar over the dimension table and the recommendation (beside it when wide)."""

    class SortChosen(Message):
        """The operator clicked the header of a column the dimensions can be sorted by."""

        def __init__(self, key: str) -> None:
            super().__init__()
            self.key = key  #: the column (one of :data:`setupfix.views.correction.SORT_KEYS`)

    def __init__(self, title: str, *, id: str | None = None) -> None:
        super().__init__(title, id=id)
        self.wide = False  #: the terminal is at least :data:`WIDE` columns wide
        self.short = False  #: the terminal is less than :data:`TALL` lines high

    def compose(self) -> ComposeResult:
        yield SummaryBar(id="summary")
        with Horizontal(id="correct-body"):
            yield DimensionTable(id="dimensions")
            yield RegisterTable(id="registers")

    def fit(self, width: int, height: int) -> bool:
        """Take the terminal's size; True when the layout changed between narrow and wide, short and tall."""
        wide, short = width >= WIDE, height < TALL
        changed = (wide, short) != (self.wide, self.short)
        self.wide, self.short = wide, short
        return changed

    def show(self, state: SessionState) -> None:
        """Lay out the cycle on screen of ``state`` (or why there is none)."""
        c = state.current()
        opened = state.opened
        summary = self.query_one(SummaryBar)
        if c is None:
            reason = state.problem or (
                f"✗ {opened.problem} (tab 5 shows the match table)" if opened and opened.problem else ""
            )
            summary.show(None, optimizer=state.optimizer, problem=reason)
            self.query_one(DimensionTable).clear(columns=True)
            self.query_one(RegisterTable).clear(columns=True)
            return
        n = len(opened.corrections) if opened else 1
        part = f"part {c.part.part or '—'}" + (f" ({state.part_index + 1}/{n}, [ ] to change)" if n > 1 else "")
        head = view.summary(c)
        reader = tuple(f"⚠ {n}" for n in opened.notes) if opened else ()
        current = f"⚠ {state.current_problem}; exports are changes (add)" if state.current_problem else ""
        summary.show(
            head,
            optimizer=state.optimizer,
            part=part,
            problem="\n".join(t for t in (current, state.problem, c.thermal.line() if c.thermal else "", *reader) if t),
        )
        rows = view.filter_rows(view.dimension_rows(c), state.station)
        small = self.short or not self.wide
        if state.sort_key is not None:
            rows = view.sort_rows(rows, state.sort_key)
        elif small:  # a small screen shows what needs the operator first: out, binding or at a limit, least margin
            rows = attention_order(rows)
        dims = self.query_one(DimensionTable)
        dims.show(rows, wide=self.wide)
        order = state.sort_key or ("out, binding, margin" if small else "model")
        dims.border_title = escape(f"dimensions · station {state.station or 'all'} · sort {order}")
        # short and narrow: the table takes the room the registers leave (app.tcss: they get at most 45 %)
        m = c.model
        registers = self.query_one(RegisterTable)
        registers.show(
            view.register_rows(c, opened.current if opened else None),
            unit=m.unit,
            digits=grid_decimals(m.resolution),
            rotation_digits=grid_decimals(m.rotation_resolution),
        )
        where = f"axes {' '.join(m.axes)}" if m.multi_axis else f"axis {m.axis}"
        registers.border_title = escape(
            f"recommendation [{m.unit}, {where}]" + (" · --current does not fit: changes only" if current else "")
        )

    @on(DataTable.HeaderSelected, "#dimensions")
    def _header(self, event: DataTable.HeaderSelected) -> None:
        key = str(event.column_key.value)
        if key in view.SORT_KEYS:
            self.post_message(self.SortChosen(key))
