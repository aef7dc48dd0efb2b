"""The operator's screen: one App, thin; every number from :mod:`setupfix.usecases`.

The app is composed, not inherited: what the operator's session holds is a plain dataclass
(:class:`~setupfix.tui.state.SessionState`), the tabs are widgets (:mod:`setupfix.tui.widgets`) that lay it
out and post what the operator asks for as messages, the dialogs are modal screens
(:mod:`setupfix.tui.screens`), and the work — opening, correcting, comparing, diagnosing, exporting — is
done by the :class:`~setupfix.tui.controller.SessionController` the app owns.  This module holds the
layout, the key bindings and their actions, and hands messages and worker events on.

Work that reads files or optimises runs in thread workers (``exit_on_error=False``)
that get immutable inputs and return pipeline results; one handler,
:meth:`SetupfixApp.on_worker_state_changed`, passes every result and failure to the
controller, which shows results and turns every failure into a notification naming the
file and place — the same error boundary as the CLI, so a bad file never ends the app.
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

from textual import events, on
from textual.actions import SkipAction
from textual.app import App, ComposeResult
from textual.binding import Binding, BindingType
from textual.notifications import SeverityLevel
from textual.screen import ModalScreen
from textual.widgets import Footer, Header, TabbedContent, TabPane
from textual.worker import Worker

from setupfix.tui.controller import SessionController
from setupfix.tui.messages import CompareProgress
from setupfix.tui.screens import HelpScreen, OpenFileScreen
from setupfix.tui.session import OpenedReport
from setupfix.tui.state import Inputs, SessionState
from setupfix.tui.widgets import (
    TALL,
    WIDE,
    ComparePanel,
    CorrectionTab,
    HistoryPanel,
    MatchPanel,
    ThermalPanel,
)
from setupfix.usecases.compare import Comparison

__all__ = ["SetupfixApp"]


class SetupfixApp(App[None]):
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
        Binding("w", "send", "Send"),  # shown with --link only (SessionState.allows)
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
        # an engineer's keys (p, c, 2) are hidden and do nothing for an operator: ctrl+e (or --engineer) shows them
        Binding("ctrl+e", "engineer", "Engineer", show=False),
        Binding("question_mark,f1", "help", "Help"),
        Binding("q", "quit", "Quit"),
    ]

    def __init__(self, inputs: Inputs | None = None) -> None:
        super().__init__()
        self.state = SessionState.start(inputs or Inputs())  #: what the operator's session holds
        self.controller = SessionController(self, self.state)  #: the work the keys ask for, and its results

    # ----------------------------------------------------------------- the session, read through the app
    @property
    def inputs(self) -> Inputs:
        """What the command line gave."""
        return self.state.inputs

    @inputs.setter
    def inputs(self, inputs: Inputs) -> None:
        self.state.inputs = inputs

    @property
    def opened(self) -> OpenedReport | None:
        """The report opened (None before the first one, and after one failed)."""
        return self.state.opened

    @property
    def problem(self) -> str:
        """Why nothing is on screen, or what is under way ("" when a correction is shown)."""
        return self.state.problem

    @property
    def current_problem(self) -> str:
        """Why ``--current`` does not fit the model opened ("" when it fits or is not given)."""
        return self.state.current_problem

    @property
    def optimizer(self) -> str:
        """The optimiser of the next run."""
        return self.state.optimizer

    @property
    def sort_key(self) -> str | None:
        """The sort of the dimensions (None: the model's order)."""
        return self.state.sort_key

    @sort_key.setter
    def sort_key(self, key: str | None) -> None:
        self.state.sort_key = key

    @property
    def comparison(self) -> Comparison | None:
        """The last comparison of the optimisers."""
        return self.state.comparison

    @comparison.setter
    def comparison(self, comparison: Comparison | None) -> None:
        self.state.comparison = comparison

    # ----------------------------------------------------------------- layout
    def compose(self) -> ComposeResult:
        yield Header()
        with TabbedContent(initial="correct"):
            yield CorrectionTab("1 Correction", id="correct")
            with TabPane("2 Compare", id="compare"):
                yield ComparePanel(id="compare-panel")
            with TabPane("3 Thermal", id="thermal"):
                yield ThermalPanel(id="thermal-panel")
            with TabPane("4 History", id="history"):
                yield HistoryPanel(id="history-panel")
            with TabPane("5 Match", id="match"):
                yield MatchPanel()
        yield Footer()

    def on_mount(self) -> None:
        self.query_one(CorrectionTab).fit(self.size.width, self.size.height)
        self._show_engineer_tabs()
        self.controller.start()

    def _show_engineer_tabs(self) -> None:
        """The compare tab for an engineer only (an operator never lands on it)."""
        tabs = self.query_one(TabbedContent)
        if self.state.engineer:
            tabs.show_tab("compare")
        else:
            if tabs.active == "compare":
                tabs.active = "correct"
            tabs.hide_tab("compare")

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        """An engineer's action (the optimiser choice, the comparison, its tab) is hidden from an operator."""
        if action == "tab" and parameters == ("compare",):
            return self.state.engineer
        return self.state.allows(action)

    def on_resize(self, event: events.Resize) -> None:
        # Rebuild the tables only when the layout changes between narrow and wide, short and tall.
        if self.query_one(CorrectionTab).fit(event.size.width, event.size.height):
            self.controller.show()

    def notify(
        self,
        message: str,
        *,
        title: str = "",
        severity: SeverityLevel = "information",
        timeout: float | None = None,
        markup: bool = False,
    ) -> None:
        """A toast; its text (names of files, reports, dimensions) is literal, not markup."""
        super().notify(message, title=title, severity=severity, timeout=timeout, markup=markup)

    # ----------------------------------------------------------------- messages and worker events
    def on_worker_state_changed(self, event: Worker.StateChanged) -> None:
        """Every worker's result or failure, to the controller (the error boundary)."""
        self.controller.worker_changed(event)

    @on(CompareProgress)
    def _compare_progress(self, message: CompareProgress) -> None:
        self.query_one(ComparePanel).progress(message.done, message.total, message.method)

    @on(CorrectionTab.SortChosen)
    def _sort_chosen(self, message: CorrectionTab.SortChosen) -> None:
        self.state.sort_by(message.key)
        self.controller.show()

    # ----------------------------------------------------------------- key actions
    def action_run(self) -> None:
        """Correct the report again with the chosen optimiser."""
        self.controller.run()

    def action_next_optimizer(self) -> None:
        """Cycle exact → cripso → … and run at once."""
        self.state.next_optimizer()
        self.notify(f"optimiser {self.state.optimizer}", timeout=2)
        self.controller.run()

    def action_compare(self) -> None:
        self.controller.compare()

    def action_cancel(self) -> None:
        running = [w for w in self.workers if w.is_running]
        for w in running:
            w.cancel()
        self.notify("cancelled" if running else "nothing is running", timeout=3)

    def action_filter_station(self) -> None:
        if self.state.next_station():
            self.controller.show()

    def action_sort(self) -> None:
        self.state.next_sort()
        self.controller.show()

    def action_part(self, step: int) -> None:
        if self.state.step_part(step):
            self.controller.show()

    def action_cycle(self, which: str) -> None:
        """Home/End: the first or the latest cycle (part) of a multi-cycle report, in report order."""
        if isinstance(self.screen, ModalScreen):
            raise SkipAction  # the key is the dialog's (a text field's Home/End)
        if self.state.jump_part(which):
            self.controller.show()

    def action_capability(self) -> None:
        """Capability per stored dimension (``setupfix spc`` of the history store), over the screen."""
        self.controller.capability()

    def action_tab(self, tab: str) -> None:
        self.query_one(TabbedContent).active = tab

    def action_help(self) -> None:
        self.push_screen(HelpScreen())

    def action_engineer(self) -> None:
        """ctrl+e: the engineer's keys and the compare tab shown, or hidden again."""
        self.state.engineer = not self.state.engineer
        self._show_engineer_tabs()
        self.refresh_bindings()
        self.notify(
            "engineer mode: p optimiser, c compare, 2 compare tab (ctrl+e hides them)"
            if self.state.engineer
            else "operator mode: the optimiser choice and the comparison are hidden (ctrl+e shows them)",
            timeout=4,
        )

    def action_diagnose(self) -> None:
        """Diagnose the series: the history store, else the reports in the current (or watched) folder."""
        self.controller.diagnose()

    def action_open_report(self) -> None:
        start = self.state.report_path or Path.cwd()
        self.push_screen(
            OpenFileScreen("Open a report (any supported format) or a folder to watch", start),
            self.controller.report_picked,
        )

    def action_open_model(self) -> None:
        self.push_screen(
            OpenFileScreen("Open a process model (TOML)", self.state.model_path or Path.cwd()),
            self.controller.model_picked,
        )

    def action_export(self) -> None:
        self.controller.export()

    def action_send(self) -> None:
        """Send the cycle on screen to the machine (``--link``): the dry-run diff, then two confirmations."""
        self.controller.send()
