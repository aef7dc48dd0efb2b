"""The app's thread workers started and their results shown: the one error boundary of the app.

Work that reads files or optimises runs in thread workers (``exit_on_error=False``) that get immutable inputs
and return pipeline results; :meth:`WorkerResults.on_worker_state_changed` shows results and turns every
failure into a notification naming the file and place.
"""

from __future__ import annotations

from functools import partial
from pathlib import Path

from textual import on
from textual.markup import escape
from textual.widgets import Static, TabbedContent
from textual.worker import Worker, WorkerState

from setupfix.core.errors import SetupfixError
from setupfix.tui import workers
from setupfix.tui.display import CorrectionDisplay
from setupfix.tui.messages import CompareProgress
from setupfix.tui.screens import CapabilityScreen
from setupfix.tui.session import OpenedReport
from setupfix.tui.widgets import ComparePanel, HistoryPanel, MatchTable, ThermalPanel
from setupfix.tui.widgets.plain import plain
from setupfix.usecases.compare import Comparison
from setupfix.usecases.requests import SolveOptions
from setupfix.usecases.spc_report import SpcOutcome
from setupfix.views import analysis as analysis_view

__all__ = ["WorkerResults"]


class WorkerResults(CorrectionDisplay):
    """Starts the open and thermal workers, receives every worker's result or failure, watches a folder."""

    def _start_open(self) -> None:
        if self.model_path is None or self.report_path is None:
            self.problem = (
                "No model: press m to open the process model."
                if self.model_path is None
                else "No report: press o to open one."
            )
            self._show()
            return
        self.problem = f"opening {self.report_path} …"
        self._show()
        i = self.inputs
        thermal = (i.thermal, i.temperatures, i.at, i.thermal_dead_band) if i.thermal and i.temperatures else None
        self.run_worker(
            partial(
                workers.open_report,
                self.model_path,
                self.report_path,
                read=i.read,
                cycles=i.cycles,
                solve=SolveOptions(self.optimizer, i.seed, None, i.objective if self.optimizer == "exact" else None),
                db=i.store,
                current=i.current,
                thermal=thermal,
            ),
            name="open",
            group="open",
            thread=True,
            exclusive=True,
            exit_on_error=False,
        )

    def _start_thermal(self) -> None:
        panel = self.query_one(ThermalPanel)
        if self.inputs.thermal is None or self.inputs.temperatures is None:
            missing = "--thermal MODEL.json" if self.inputs.thermal is None else "--temperatures LOG"
            panel.not_available(f"no thermal model and log given ({missing})")
            return
        panel.not_available(f"predicting drift from {self.inputs.temperatures} …")
        self.run_worker(
            partial(workers.drift, self.inputs.thermal, self.inputs.temperatures),
            name="thermal",
            group="thermal",
            thread=True,
            exclusive=True,
            exit_on_error=False,
        )

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
            elif worker.name == "diagnose" and isinstance(worker.result, analysis_view.DiagnosisView):
                self.query_one(HistoryPanel).diagnosis(worker.result, source=self._series_source())
            elif worker.name == "thermal" and isinstance(worker.result, analysis_view.DriftView):
                self.query_one(ThermalPanel).show(worker.result, source=str(self.inputs.temperatures))

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
            status.update(
                plain(
                    f"✗ {opened.problem}\nEach characteristic of the report, ✓ with the dimension it "
                    "matches, ✗ with the closest dimension names:"
                )
            )
            self.query_one(TabbedContent).active = "match"
        elif opened.unmatched:
            status.update(
                f"⚠ {opened.unmatched} characteristic(s) of the report match no dimension "
                "(✗ below, with the closest dimension names); they are left out."
            )
        else:
            status.update("✓ every characteristic of the report matches a dimension of the model.")
        self._show()
        store = self.inputs.store
        if store is not None and not store.exists:  # reading never creates it
            self.query_one(HistoryPanel).status(
                f"no history store at {self.inputs.db} yet: the first export creates it"
            )
        elif store is not None:
            self.run_worker(
                partial(workers.history, opened.model, store),
                name="history",
                group="history",
                thread=True,
                exclusive=True,
                exit_on_error=False,
            )

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
        panel.show(
            analysis_view.compare_rows(comparison),
            analysis_view.convergence(comparison, 60),
            exact_f1=comparison.exact.margin_after,
            unit=self._unit(),
            heading=f"{comparison.trials} seeded trials per method (seed {comparison.seed})"
            + (f" on {c.part.report} {c.part.part}" if c else ""),
        )

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
