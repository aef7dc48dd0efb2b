"""The operator's screen: one App, thin; every number from :mod:`setupfix.usecases`.

The app is built in layers, each a module: its inputs and state (:mod:`~setupfix.tui.state`), the
correction tab on screen (:mod:`~setupfix.tui.display`), the workers and their results
(:mod:`~setupfix.tui.worker_results`), the keys' actions (:mod:`~setupfix.tui.actions`); this
module adds the layout, the key bindings and the start.

Work that reads files or optimises runs in thread workers (``exit_on_error=False``)
that get immutable inputs and return pipeline results; one handler,
:meth:`SetupfixApp.on_worker_state_changed`, shows results and turns every failure
into a notification naming the file and place — the same error boundary as the CLI,
so a bad file never ends the app.
"""

from __future__ import annotations

from typing import ClassVar

from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Horizontal, Vertical
from textual.widgets import Footer, Header, Static, TabbedContent, TabPane

from setupfix.tui.actions import KeyActions
from setupfix.tui.display import TALL, WIDE
from setupfix.tui.session import FolderWatch
from setupfix.tui.widgets import (
    ComparePanel,
    DimensionTable,
    HistoryPanel,
    MatchTable,
    RegisterTable,
    SummaryBar,
    ThermalPanel,
)

__all__ = ["SetupfixApp"]


class SetupfixApp(KeyActions):
    """setupfix's Textual app; build it with :class:`~setupfix.tui.state.Inputs` (tests do the same)."""

    CSS_PATH = "app.tcss"
    #: The footer's room is worth more than the palette: every action has a key (see ?).
    ENABLE_COMMAND_PALETTE = False
    TITLE = "setupfix"
    # Textual declares these as class-level lists (its own annotation); RUF012 cannot see the base class.
    HORIZONTAL_BREAKPOINTS = [(0, "-narrow"), (WIDE, "-wide")]  # noqa: RUF012 - Textual's declared type
    VERTICAL_BREAKPOINTS = [(0, "-short"), (TALL, "-tall")]  # noqa: RUF012 - Textual's declared type
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("o", "open_report", "Open"),
        Binding("m", "open_model", "Model", show=False),
        Binding("r", "run", "Run"),
        Binding("p", "next_optimizer", "Optim."),
        Binding("c", "compare", "Compare"),
        Binding("x", "cancel", "Cancel", show=False),
        Binding("f", "filter_station", "Station"),
        Binding("s", "sort", "Sort"),
        Binding("e", "export", "Export"),
        Binding("d", "diagnose", "Diagnose", show=False),
        Binding("left_square_bracket", "part(-1)", "Prev part", show=False),
        Binding("right_square_bracket", "part(1)", "Next part", show=False),
        # priority: a focused table would scroll instead (a modal screen's field keeps them, see action_cycle)
        Binding("home", "cycle('first')", "First cycle", show=False, priority=True),
        Binding("end", "cycle('latest')", "Latest cycle", show=False, priority=True),
        Binding("k", "capability", "Capability", show=False),
        Binding("1", "tab('correct')", "Correction", show=False),
        Binding("2", "tab('compare')", "Compare", show=False),
        Binding("3", "tab('thermal')", "Thermal", show=False),
        Binding("4", "tab('history')", "History", show=False),
        Binding("5", "tab('match')", "Match", show=False),
        Binding("question_mark,f1", "help", "Help"),
        Binding("q", "quit", "Quit"),
    ]

    # ----------------------------------------------------------------- layout
    def compose(self) -> ComposeResult:
        yield Header()
        with TabbedContent(initial="correct"):
            with TabPane("1 Correction", id="correct"):
                yield SummaryBar(id="summary")
                with Horizontal(id="correct-body"):
                    yield DimensionTable(id="dimensions")
                    yield RegisterTable(id="registers")
            with TabPane("2 Compare", id="compare"):
                yield ComparePanel(id="compare-panel")
            with TabPane("3 Thermal", id="thermal"):
                yield ThermalPanel(id="thermal-panel")
            with TabPane("4 History", id="history"):
                yield HistoryPanel(id="history-panel")
            with TabPane("5 Match", id="match"), Vertical():
                yield Static("The report matches the model.", id="match-status")
                yield MatchTable(id="match-table")
        yield Footer()

    def on_mount(self) -> None:
        self._wide = self.size.width >= WIDE
        self._short = self.size.height < TALL
        self._show()
        self._start_thermal()
        self.query_one(HistoryPanel).status(
            "no history store given (--db STORE): d diagnoses the reports in the current report's folder"
            if self.inputs.db is None
            else f"reading the history store {self.inputs.db} …"
        )
        report = self.inputs.report
        if report is not None and report.is_dir():
            self.folder_watch = FolderWatch(report, settle=self.inputs.poll_seconds)
            self.set_interval(self.inputs.poll_seconds, self._poll_folder)
            self._poll_folder()
        elif report is not None:
            self.report_path = report
            self._start_open()
