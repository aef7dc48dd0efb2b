"""What the app's keys do: run, compare, filter, sort, change cycle, open, export, diagnose, capability."""

from __future__ import annotations

from functools import partial
from pathlib import Path

from textual.actions import SkipAction
from textual.screen import ModalScreen
from textual.widgets import TabbedContent

from setupfix.core.errors import SetupfixError
from setupfix.optimize import OPTIMIZERS
from setupfix.tui import workers
from setupfix.tui.exporting import CONTROLLERS, export_name, preview, write_offsets
from setupfix.tui.screens import ExportRequest, ExportScreen, HelpScreen, OpenFileScreen
from setupfix.tui.session import FolderWatch, OpenedReport, record_applied
from setupfix.tui.widgets import ComparePanel, HistoryPanel
from setupfix.tui.worker_results import WorkerResults
from setupfix.usecases.compare import DEFAULT_METHODS
from setupfix.views import correction as view

__all__ = ["KeyActions", "SORT_ORDER"]


#: What ``s`` cycles through: None is the model's order.
SORT_ORDER: tuple[str | None, ...] = (None, "margin_after", "deviation", "name", "station")


class KeyActions(WorkerResults):
    """The ``action_*`` methods named by the bindings of :class:`~setupfix.tui.app.SetupfixApp`; their dialogs'
    callbacks."""

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
        self.run_worker(
            partial(workers.compare, self, c.posed.guarded, self.inputs.trials, self.inputs.seed),
            name="compare",
            group="compare",
            thread=True,
            exclusive=True,
            exit_on_error=False,
        )

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
            self.notify(
                "no history store given: start with --db STORE (capability is computed from the stored measurements)",
                title="capability",
                severity="warning",
                timeout=8,
            )
            return
        self.notify(f"computing capability from {self.inputs.db} …", timeout=3)
        self.run_worker(
            partial(workers.capability, self.inputs.store),
            name="capability",
            group="capability",
            thread=True,
            exclusive=True,
            exit_on_error=False,
        )

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
        self.run_worker(
            partial(workers.diagnose, self.model_path, source, self.inputs.process, self.inputs.factors),
            name="diagnose",
            group="diagnose",
            thread=True,
            exclusive=True,
            exit_on_error=False,
        )

    def action_open_report(self) -> None:
        start = self.report_path or Path.cwd()
        self.push_screen(
            OpenFileScreen("Open a report (any supported format) or a folder to watch", start), self._picked_report
        )

    def action_open_model(self) -> None:
        self.push_screen(
            OpenFileScreen("Open a process model (TOML)", self.model_path or Path.cwd()), self._picked_model
        )

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
        self.push_screen(
            ExportScreen(CONTROLLERS, preview(self.opened, self.part_index), self.inputs.offsets, rename=export_name),
            partial(self._export_confirmed, self.opened, self.part_index),
        )

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
