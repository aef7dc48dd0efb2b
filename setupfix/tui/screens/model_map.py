"""The ``model map`` screen: a scaffold's open questions in a table; mark some, give WKS and tool, answer.

Everything goes through :mod:`setupfix.usecases.model_map` (the listing, the answers, the
atomic write) and the rows through :func:`setupfix.views.model_map.question_rows`, as the
command line does.  ``space`` marks a row (answered together: features sharing a tool or a
station), ``a`` marks every row, Enter in the tool field answers the marked rows (the row
under the cursor when none is marked).
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

from textual import on
from textual.app import App, ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Horizontal
from textual.screen import Screen
from textual.widgets import DataTable, Footer, Input, Label

from setupfix.core.errors import SetupfixError, SourceLocation
from setupfix.usecases.model_map import Answer, answer_questions, map_listing
from setupfix.views.model_map import COLUMNS, format_result, question_rows

__all__ = ["ModelMapScreen", "ModelMapApp", "run_model_map"]

_MARK = "●"


class ModelMapScreen(Screen[None]):
    """The open questions of one model; answers are written at once (atomically) and the table reloads."""

    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("space", "mark", "Mark"),
        Binding("a", "mark_all", "Mark all"),
        Binding("escape", "leave", "Quit"),
    ]

    def __init__(self, model: Path, *, out: Path | None = None, keep_draft: bool = False) -> None:
        super().__init__()
        self.model = model
        self.out = out
        self.keep_draft = keep_draft
        self.marked: set[str] = set()
        self.written = False

    @property
    def current(self) -> Path:
        """The file the questions are read from: the model, or ``out`` once an answer went there."""
        return self.out if self.written and self.out is not None else self.model

    def compose(self) -> ComposeResult:
        yield Label("", id="map-title")
        yield DataTable(id="map-table", cursor_type="row")
        with Horizontal(id="map-answer"):
            yield Input(placeholder="work offset (G54, W1, none)", id="map-wks")
            yield Input(placeholder="tool (T5, H5, 5, none): Enter answers", id="map-tool")
        yield Label("", id="map-status")
        yield Footer()

    def on_mount(self) -> None:
        table = self.query_one("#map-table", DataTable)
        table.add_columns("", *COLUMNS)
        self.reload()
        table.focus()

    def reload(self) -> None:
        """Read the questions again and show them (marks of answered questions go)."""
        listing = map_listing(self.current)
        rows = question_rows(listing)
        self.marked &= {r[0] for r in rows}
        table = self.query_one("#map-table", DataTable)
        table.clear()
        for row in rows:
            table.add_row(_MARK if row[0] in self.marked else "", *row, key=row[0])
        state = "draft" if listing.draft else "not a draft"
        self.query_one("#map-title", Label).update(
            f"{self.current}: {len(rows)} open question(s) ({state}); space marks, a marks all, "
            "give WKS and tool, Enter answers"
        )

    def _selected(self) -> list[str]:
        if self.marked:
            return sorted(self.marked, key=lambda q: int(q[1:]) if q[1:].isdigit() else 0)
        table = self.query_one("#map-table", DataTable)
        if table.row_count == 0:
            return []
        key = table.coordinate_to_cell_key(table.cursor_coordinate).row_key.value
        return [str(key)] if key is not None else []

    def action_mark(self) -> None:
        table = self.query_one("#map-table", DataTable)
        if table.row_count == 0:
            return
        key = str(table.coordinate_to_cell_key(table.cursor_coordinate).row_key.value)
        self.marked ^= {key}
        table.update_cell(key, table.ordered_columns[0].key, _MARK if key in self.marked else "")

    def action_mark_all(self) -> None:
        table = self.query_one("#map-table", DataTable)
        keys = [str(row.key.value) for row in table.ordered_rows]
        self.marked = set() if self.marked >= set(keys) else set(keys)
        for key in keys:
            table.update_cell(key, table.ordered_columns[0].key, _MARK if key in self.marked else "")

    @on(Input.Submitted, "#map-tool")
    @on(Input.Submitted, "#map-wks")
    def _answer(self, event: Input.Submitted) -> None:
        if event.input.id == "map-wks":
            self.query_one("#map-tool", Input).focus()
            return
        selected = self._selected()
        status = self.query_one("#map-status", Label)
        if not selected:
            status.update("no open question to answer")
            return
        wks = self.query_one("#map-wks", Input).value.strip()
        tool = self.query_one("#map-tool", Input).value.strip()
        where = SourceLocation("model map screen")
        answers = [Answer(q, wks, tool, where) for q in selected]
        target = self.out if self.out is not None else self.model
        try:
            result = answer_questions(self.current, answers, out=target, keep_draft=self.keep_draft)
        except SetupfixError as exc:
            status.update(f"refused: {exc}")
            return
        self.written = True
        self.marked.clear()
        status.update(format_result(result, str(target)))
        self.reload()
        self.query_one("#map-table", DataTable).focus()

    def action_leave(self) -> None:
        self.app.exit()


class ModelMapApp(App[None]):
    """``setupfix model map MODEL --tui``: the map screen on its own."""

    TITLE = "setupfix model map"

    def __init__(self, model: Path, *, out: Path | None = None, keep_draft: bool = False) -> None:
        super().__init__()
        self.map_screen = ModelMapScreen(model, out=out, keep_draft=keep_draft)

    def on_mount(self) -> None:
        self.push_screen(self.map_screen)


def run_model_map(model: str | Path, *, out: str | Path | None = None, keep_draft: bool = False) -> int:
    """Run the screen on ``model`` (its listing first, so a model that does not load is refused before)."""
    map_listing(model)
    ModelMapApp(Path(model), out=Path(out) if out is not None else None, keep_draft=keep_draft).run()
    return 0
