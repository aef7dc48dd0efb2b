"""The operator's screen: one App, thin; every number from :mod:`setupfix.pipeline`.

Work that reads files or optimises runs in thread workers (``exit_on_error=False``)
that get immutable inputs and return pipeline results; one handler,
:meth:`SetupfixApp.on_worker_state_changed`, shows results and turns every failure
into a notification naming the file and place — the same error boundary as the CLI,
so a bad file never ends the app.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import ClassVar

from textual import events, on
from textual.app import App, ComposeResult
from textual.actions import SkipAction
from textual.binding import Binding, BindingType
from textual.containers import Horizontal, Vertical
from textual.widgets import DataTable, Footer, Header, Static, TabbedContent, TabPane
from textual.markup import escape
from textual.notifications import SeverityLevel
from textual.screen import ModalScreen
from textual.worker import Worker, WorkerState

from setupfix.errors import SetupfixError
from setupfix.offsets import grid_decimals
from setupfix.optimize import OPTIMIZERS
from setupfix.pipeline import view
from setupfix.pipeline.compare import DEFAULT_METHODS, Comparison
from setupfix.pipeline.requests import CycleCorrection, CycleOptions, ReadOptions, SolveOptions
from setupfix.pipeline.session import FolderWatch, OpenedReport, record_applied
from setupfix.pipeline.spc import SpcOutcome
from setupfix.pipeline.stores import StoreRef
from setupfix.tui import workers
from setupfix.tui.exporting import CONTROLLERS, export_name, preview, write_offsets
from setupfix.tui.messages import CompareProgress
from setupfix.tui.screens import CapabilityScreen, ExportRequest, ExportScreen, HelpScreen, OpenFileScreen
from setupfix.tui.widgets import (ComparePanel, DimensionTable, HistoryPanel, MatchTable, RegisterTable, SummaryBar,
                                  ThermalPanel)
from setupfix.tui.widgets.plain import plain

__all__ = ["SetupfixApp", "SORT_ORDER"]

#: Columns from which the recommendation sits beside the dimensions and margins are shown.
WIDE = 120
#: Lines below which the screen is short: a compact summary, the dimensions out of tolerance first.
TALL = 30

#: What ``s`` cycles through: None is the model's order.
SORT_ORDER: tuple[str | None, ...] = (None, "margin_after", "deviation", "name", "station")

@dataclass(frozen=True)
class Inputs:
    """What the command line gave (paths as typed)."""

    model: Path | None = None
    report: Path | None = None
    db: str | None = None  #: history store: a file or a postgresql:// URL
    machine: str | None = None  #: ``--machine`` (default: the model's ``[process] machine``)
    operator: str | None = None  #: ``--operator`` (default: the login name)
    current: Path | None = None
    thermal: Path | None = None
    temperatures: Path | None = None
    process: Path | None = None  #: process log the diagnosis joins per part (``--process``)
    at: str | None = None  #: time of the correction for the feed-forward (default: the log's last sample)
    thermal_dead_band: float | None = None
    read: ReadOptions = field(default_factory=ReadOptions)  #: the reader's options, as ``correct`` takes them
    cycles: CycleOptions = field(default_factory=CycleOptions)  #: stations, parts per cycle, strictness
    optimizer: str = "exact"
    objective: str | None = None  #: the exact optimiser's objective (leximin or paper; None: its default)
    seed: int = 0
    trials: int = 12
    offsets: str = "offsets.csv"
    poll_seconds: float = 2.0

    @property
    def store(self) -> StoreRef | None:
        """The history store with its machine and operator (None without ``--db``)."""
        return None if self.db is None else StoreRef(self.db, self.machine, self.operator)


class SetupfixApp(App[None]):
    """setupfix's Textual app; build it with :class:`Inputs` (tests do the same)."""

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

    def __init__(self, inputs: Inputs | None = None) -> None:
        super().__init__()
        self.inputs = inputs or Inputs()
        self.model_path = self.inputs.model
        self.report_path: Path | None = None
        self.optimizer = self.inputs.optimizer
        self.opened: OpenedReport | None = None
        self.part_index = 0
        self.station: str | None = None
        self.sort_key: str | None = None
        self.comparison: Comparison | None = None
        self.folder_watch: FolderWatch | None = None
        self.problem = ""
        self._wide = False
        self._short = False
        self.current_problem = ""  #: why --current does not fit the model opened ("" when it fits or is not given)

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
            if self.inputs.db is None else f"reading the history store {self.inputs.db} …")
        report = self.inputs.report
        if report is not None and report.is_dir():
            self.folder_watch = FolderWatch(report, settle=self.inputs.poll_seconds)
            self.set_interval(self.inputs.poll_seconds, self._poll_folder)
            self._poll_folder()
        elif report is not None:
            self.report_path = report
            self._start_open()

    # ----------------------------------------------------------------- workers
    def _start_open(self) -> None:
        if self.model_path is None or self.report_path is None:
            self.problem = ("No model: press m to open the process model." if self.model_path is None
                            else "No report: press o to open one.")
            self._show()
            return
        self.problem = f"opening {self.report_path} …"
        self._show()
        i = self.inputs
        thermal = (i.thermal, i.temperatures, i.at, i.thermal_dead_band) if i.thermal and i.temperatures else None
        self.run_worker(partial(workers.open_report, self.model_path, self.report_path, read=i.read, cycles=i.cycles,
                                solve=SolveOptions(self.optimizer, i.seed, None,
                                                   i.objective if self.optimizer == "exact" else None),
                                db=i.store, current=i.current,
                                thermal=thermal),
                        name="open", group="open", thread=True, exclusive=True, exit_on_error=False)

    def _start_thermal(self) -> None:
        panel = self.query_one(ThermalPanel)
        if self.inputs.thermal is None or self.inputs.temperatures is None:
            missing = "--thermal MODEL.json" if self.inputs.thermal is None else "--temperatures LOG"
            panel.not_available(f"no thermal model and log given ({missing})")
            return
        panel.not_available(f"predicting drift from {self.inputs.temperatures} …")
        self.run_worker(partial(workers.drift, self.inputs.thermal, self.inputs.temperatures), name="thermal",
                        group="thermal", thread=True, exclusive=True, exit_on_error=False)

    def _feed_text(self) -> str:
        """The cycle's thermal feed-forward (part of its corrections and of the exported offsets)."""
        c = self._current()
        if c is None or c.thermal is None:
            return ""
        return c.thermal.line() + "; added to the exported offsets"

    def on_worker_state_changed(self, event: Worker.StateChanged) -> None:
        """The error boundary and the one place results reach the screen."""
        worker = event.worker
        if event.state == WorkerState.ERROR:
            self._failed(worker.name, worker.error)
        elif event.state == WorkerState.CANCELLED and worker.name == "compare":
            self.query_one(ComparePanel).stopped("comparison cancelled")
        elif event.state == WorkerState.SUCCESS:
            if worker.name == "open" and isinstance(worker.result, tuple):
                opened, self.current_problem = worker.result
                if self.current_problem:
                    self.notify(self.current_problem, title="current offsets", severity="warning", timeout=12)
                self._opened(opened)
            elif worker.name == "capability" and isinstance(worker.result, SpcOutcome):
                self.push_screen(CapabilityScreen(worker.result))
            elif worker.name == "compare":
                self._compared(worker.result)
            elif worker.name == "history" and isinstance(worker.result, tuple):
                budgets, notes = worker.result
                self.query_one(HistoryPanel).budgets(budgets, unit=self._unit(), source=str(self.inputs.db))
                for note in notes:
                    self.notify(note, title="history", severity="warning")
            elif worker.name == "diagnose" and isinstance(worker.result, view.DiagnosisView):
                self.query_one(HistoryPanel).diagnosis(worker.result, source=self._series_source())
            elif worker.name == "thermal" and isinstance(worker.result, view.DriftView):
                self.query_one(ThermalPanel).show(worker.result, source=str(self.inputs.temperatures))

    def notify(self, message: str, *, title: str = "", severity: SeverityLevel = "information",
               timeout: float | None = None, markup: bool = False) -> None:
        """A toast; its text (names of files, reports, dimensions) is literal, not markup."""
        super().notify(message, title=title, severity=severity, timeout=timeout, markup=markup)

    def _failed(self, what: str, error: BaseException | None) -> None:
        text = str(error) if isinstance(error, SetupfixError) else f"internal error: {type(error).__name__}: {error}"
        self.notify(text, title=f"{what} failed", severity="error", timeout=12)
        if what == "open":
            # The previous correction is no longer what the operator asked for: showing
            # (and exporting) it beside a failed report would invite applying stale offsets.
            self.opened = None
            self.sub_title = ""
            self.problem = f"✗ {text}"
            self._show()
        elif what == "compare":
            self.query_one(ComparePanel).stopped(f"✗ {text}")
        elif what == "thermal":
            self.query_one(ThermalPanel).not_available(text)
        elif what in ("history", "diagnose", "capability"):
            self.query_one(HistoryPanel).status(f"✗ {text}")

    def _opened(self, opened: OpenedReport) -> None:
        # Work started for the previous report must not land on this one.
        self.workers.cancel_group(self, "compare")
        self.opened = opened
        self.problem = ""
        self.part_index = min(self.part_index, max(len(opened.corrections) - 1, 0))
        self.sub_title = escape(f"{Path(opened.report).name} · {opened.format} · {Path(opened.model.source).name}")
        status = self.query_one("#match-status", Static)
        table = self.query_one(MatchTable)
        table.show(opened.matches)
        if not opened.corrections:
            status.update(plain(f"✗ {opened.problem}\nEach characteristic of the report, ✓ with the dimension it "
                                "matches, ✗ with the closest dimension names:"))
            self.query_one(TabbedContent).active = "match"
        elif opened.unmatched:
            status.update(f"⚠ {opened.unmatched} characteristic(s) of the report match no dimension "
                          "(✗ below, with the closest dimension names); they are left out.")
        else:
            status.update("✓ every characteristic of the report matches a dimension of the model.")
        self._show()
        store = self.inputs.store
        if store is not None and not store.exists:  # reading never creates it
            self.query_one(HistoryPanel).status(f"no history store at {self.inputs.db} yet: the first export "
                                                "creates it")
        elif store is not None:
            self.run_worker(partial(workers.history, opened.model, store), name="history", group="history",
                            thread=True, exclusive=True, exit_on_error=False)

    def _compared(self, comparison: object) -> None:
        panel = self.query_one(ComparePanel)
        if not isinstance(comparison, Comparison):
            panel.stopped("comparison cancelled")
            return
        c = self._current()
        if c is None or comparison.problem is not c.posed.guarded:
            panel.stopped("that comparison was for a previous report: press c to compare this one")
            return
        self.comparison = comparison
        panel.show(view.compare_rows(comparison), view.convergence(comparison, 60),
                   exact_f1=comparison.exact.margin_after, unit=self._unit(),
                   heading=f"{comparison.trials} seeded trials per method (seed {comparison.seed})"
                           + (f" on {c.part.report} {c.part.part}" if c else ""))

    @on(CompareProgress)
    def _compare_progress(self, message: CompareProgress) -> None:
        self.query_one(ComparePanel).progress(message.done, message.total, message.method)

    def _poll_folder(self) -> None:
        if self.folder_watch is None:
            return
        path = self.folder_watch.poll()
        for where, why in self.folder_watch.problems:  # named once each, never silently dropped
            self.notify(f"{where}: {why}", title="folder", severity="warning", timeout=12)
        if path is not None:
            if self.report_path is not None:
                self.notify(f"new report {path.name}", title="folder")
            self.report_path = path
            self._start_open()
        elif self.report_path is None:
            self.problem = f"watching {self.folder_watch.folder} for a report …"
            self._show()

    # ----------------------------------------------------------------- showing
    def _current(self) -> CycleCorrection | None:
        if self.opened is None or not self.opened.corrections:
            return None
        return self.opened.corrections[self.part_index]

    def _unit(self) -> str:
        return self.opened.model.unit if self.opened is not None else "mm"

    def _show(self) -> None:
        """Push the current state down into the correction tab's widgets."""
        c = self._current()
        summary = self.query_one(SummaryBar)
        if c is None:
            reason = self.problem or (f"✗ {self.opened.problem} (tab 5 shows the match table)"
                                      if self.opened and self.opened.problem else "")
            summary.show(None, optimizer=self.optimizer, problem=reason)
            self.query_one(DimensionTable).clear(columns=True)
            self.query_one(RegisterTable).clear(columns=True)
            return
        n = len(self.opened.corrections) if self.opened else 1
        part = f"part {c.part.part or '—'}" + (f" ({self.part_index + 1}/{n}, [ ] to change)" if n > 1 else "")
        head = view.summary(c)
        reader = tuple(f"⚠ {n}" for n in self.opened.notes) if self.opened else ()
        current = f"⚠ {self.current_problem}; exports are changes (add)" if self.current_problem else ""
        summary.show(head, optimizer=self.optimizer, part=part,
                     problem="\n".join(t for t in (current, self.problem, c.thermal.line() if c.thermal else "",
                                                   *reader) if t))
        if self.inputs.thermal is not None and self.inputs.temperatures is not None:
            self.query_one(ThermalPanel).feed_forward(
                self._feed_text() or f"no feed-forward for {c.part.report} {c.part.part}".rstrip())
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
        self.query_one(RegisterTable).show(view.register_rows(c, self.opened.current if self.opened else None),
                                           unit=m.unit, digits=grid_decimals(m.resolution),
                                           rotation_digits=grid_decimals(m.rotation_resolution))
        where = f"axes {' '.join(m.axes)}" if m.multi_axis else f"axis {m.axis}"
        self.query_one(RegisterTable).border_title = escape(
            f"recommendation [{m.unit}, {where}]" + (" · --current does not fit: changes only" if current else ""))

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

    # ----------------------------------------------------------------- actions
    def action_run(self) -> None:
        """Correct the report again with the chosen optimiser."""
        self._start_open()

    def action_next_optimizer(self) -> None:
        """Cycle exact → cripso → … and run at once."""
        names = list(OPTIMIZERS)
        self.optimizer = names[(names.index(self.optimizer) + 1) % len(names)] if self.optimizer in names else "exact"
        self.notify(f"optimiser {self.optimizer}", timeout=2)
        self._start_open()

    def action_compare(self) -> None:
        c = self._current()
        if c is None:
            self.notify("open a report first (o)", severity="warning")
            return
        self.query_one(TabbedContent).active = "compare"
        self.query_one(ComparePanel).progress(0, 1 + len(DEFAULT_METHODS) * self.inputs.trials, "exact")
        # the problem correct solves (guard band, cumulative bounds, costs, fixed registers): exact = the correction
        self.run_worker(partial(workers.compare, self, c.posed.guarded, self.inputs.trials, self.inputs.seed),
                        name="compare", group="compare", thread=True, exclusive=True, exit_on_error=False)

    def action_cancel(self) -> None:
        running = [w for w in self.workers if w.is_running]
        for w in running:
            w.cancel()
        self.notify("cancelled" if running else "nothing is running", timeout=3)

    def action_filter_station(self) -> None:
        c = self._current()
        if c is None:
            return
        options: list[str | None] = [None, *view.stations(view.dimension_rows(c))]
        self.station = options[(options.index(self.station) + 1) % len(options)] if self.station in options else None
        self._show()

    def action_sort(self) -> None:
        self.sort_key = SORT_ORDER[(SORT_ORDER.index(self.sort_key) + 1) % len(SORT_ORDER)]
        self._show()

    def action_part(self, step: int) -> None:
        if self.opened and self.opened.corrections:
            self.part_index = (self.part_index + step) % len(self.opened.corrections)
            self._show()

    def action_cycle(self, which: str) -> None:
        """Home/End: the first or the latest cycle (part) of a multi-cycle report, in report order."""
        if isinstance(self.screen, ModalScreen):
            raise SkipAction  # the key is the dialog's (a text field's Home/End)
        if self.opened and self.opened.corrections:
            self.part_index = 0 if which == "first" else len(self.opened.corrections) - 1
            self._show()

    def action_capability(self) -> None:
        """Capability per stored dimension (``setupfix spc`` of the history store), over the screen."""
        if self.inputs.store is None:
            self.notify("no history store given: start with --db STORE (capability is computed from the stored "
                        "measurements)", title="capability", severity="warning", timeout=8)
            return
        self.notify(f"computing capability from {self.inputs.db} …", timeout=3)
        self.run_worker(partial(workers.capability, self.inputs.store), name="capability", group="capability",
                        thread=True, exclusive=True, exit_on_error=False)

    def action_tab(self, tab: str) -> None:
        self.query_one(TabbedContent).active = tab

    def action_help(self) -> None:
        self.push_screen(HelpScreen())

    def action_diagnose(self) -> None:
        """Diagnose the series: the history store, else the reports in the current (or watched) folder."""
        self.action_tab("history")
        if self.model_path is None or self._series_source() == "":
            self.notify("open a model and a report first", severity="warning")
            return
        self.query_one(HistoryPanel).status(f"diagnosing the reports in {self._series_source()} …")
        source = self.inputs.store or Path(self._series_source())
        self.run_worker(partial(workers.diagnose, self.model_path, source, self.inputs.process),
                        name="diagnose", group="diagnose", thread=True, exclusive=True, exit_on_error=False)

    def _series_source(self) -> str:
        """The history store when given, else the watched folder or the report's folder."""
        if self.inputs.db is not None:
            return str(self.inputs.db)
        if self.folder_watch is not None:
            return str(self.folder_watch.folder)
        return str(self.report_path.parent) if self.report_path is not None else ""

    def action_open_report(self) -> None:
        start = self.report_path or Path.cwd()
        self.push_screen(OpenFileScreen("Open a report (any supported format) or a folder to watch", start),
                         self._picked_report)

    def action_open_model(self) -> None:
        self.push_screen(OpenFileScreen("Open a process model (TOML)", self.model_path or Path.cwd()),
                         self._picked_model)

    def _picked_report(self, path: Path | None) -> None:
        if path is None:
            return
        if path.is_dir():
            self.folder_watch = FolderWatch(path, settle=self.inputs.poll_seconds)
            self.report_path = None
            self.set_interval(self.inputs.poll_seconds, self._poll_folder)
            self._poll_folder()
            return
        self.folder_watch = None
        self.report_path = path
        self._start_open()

    def _picked_model(self, path: Path | None) -> None:
        if path is not None:
            self.model_path = path
            self._start_open()

    def action_export(self) -> None:
        if self.opened is None or not self.opened.corrections:
            self.notify("nothing to export: open a report that matches the model first", severity="warning")
            return
        # A controller program holds one correction: the cycle on screen ([ ] changes it).
        self.push_screen(ExportScreen(CONTROLLERS, preview(self.opened, self.part_index), self.inputs.offsets,
                                      rename=export_name),
                         partial(self._export_confirmed, self.opened, self.part_index))

    def _export_confirmed(self, opened: OpenedReport, cycle: int, request: ExportRequest | None) -> None:
        if request is None:
            self.notify("export cancelled", timeout=3)
            return
        try:
            exported = write_offsets(request, opened, cycle)
        except SetupfixError as exc:
            self.notify(str(exc), title="export failed", severity="error", timeout=12)
            return
        program = "" if exported.program_number is None else f" (program {exported.program_number})"
        self.notify(f"wrote {request.controller} offsets{program} to {request.path}", title="export")
        if self.inputs.store is not None:
            try:  # exactly what was written: its rows, and the cycles it holds
                added = record_applied(self.inputs.store, exported, opened.corrections)
            except SetupfixError as exc:
                self.notify(str(exc), title="history store", severity="error", timeout=12)
                return
            self.notify(f"recorded {added} register change(s) as applied in {self.inputs.db}", title="history")

