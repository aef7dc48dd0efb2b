"""The operator's session driven: the work the keys ask for, started in thread workers, and their results shown.

:class:`SessionController` belongs to the app and holds its :class:`~setupfix.tui.state.SessionState`.  Work
that reads files or optimises runs in thread workers (``exit_on_error=False``) that get immutable inputs and
return pipeline results (:mod:`setupfix.tui.workers`); :meth:`SessionController.worker_changed` is the one
error boundary of the app: it shows results and turns every failure into a notification naming the file and
place, so a bad file never ends the app.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

from textual.app import App
from textual.markup import escape
from textual.widgets import TabbedContent
from textual.worker import Worker, WorkerState

from setupfix.core.errors import SetupfixError
from setupfix.store import login_name
from setupfix.tui import workers
from setupfix.tui.exporting import CONTROLLERS, export_name, preview, write_offsets
from setupfix.tui.screens import CapabilityScreen, ConfirmScreen, ExportRequest, ExportScreen
from setupfix.tui.screens.send import SendScreen, outcome_line, question
from setupfix.tui.session import FolderWatch, OpenedReport, record_applied
from setupfix.tui.state import SessionState
from setupfix.tui.widgets import ComparePanel, CorrectionTab, HistoryPanel, MatchPanel, ThermalPanel
from setupfix.usecases.compare import DEFAULT_METHODS, Comparison
from setupfix.usecases.machine import WriteOutcome, WritePlan
from setupfix.usecases.requests import SolveOptions
from setupfix.usecases.spc_report import SpcOutcome
from setupfix.views import analysis as analysis_view

__all__ = ["SessionController"]


class SessionController:
    """Starts the workers of ``app`` for the session ``state``, and shows what they return in its widgets."""

    def __init__(self, app: App[None], state: SessionState) -> None:
        self.app = app
        self.state = state

    # ------------------------------------------------------------------ the screen
    def show(self) -> None:
        """Push the state down into the correction tab (and the thermal tab's feed-forward)."""
        self.app.query_one(CorrectionTab).show(self.state)
        c, i = self.state.current(), self.state.inputs
        if c is not None and i.thermal is not None and i.temperatures is not None:
            self.app.query_one(ThermalPanel).feed_forward(
                self.state.feed_text() or f"no feed-forward for {c.part.report} {c.part.part}".rstrip()
            )

    def start(self) -> None:
        """What the command line asked for: the thermal drift, the history, the report or folder opened."""
        self.show()
        self.start_thermal()
        inputs = self.state.inputs
        self.app.query_one(HistoryPanel).status(
            "no history store given (--db STORE): d diagnoses the reports in the current report's folder"
            if inputs.db is None
            else f"reading the history store {inputs.db} …"
        )
        report = inputs.report
        if report is not None and report.is_dir():
            self.watch(report)
        elif report is not None:
            self.state.report_path = report
            self.run()

    def _work(self, work: Callable[[], Any], name: str) -> None:
        """Run ``work`` in a thread worker of the app, one at a time per ``name`` (its failures: see above)."""
        self.app.run_worker(work, name=name, group=name, thread=True, exclusive=True, exit_on_error=False)

    # ------------------------------------------------------------------ work the keys ask for
    def run(self) -> None:
        """Open the report against the model and correct it with the chosen optimiser."""
        s, i = self.state, self.state.inputs
        if s.model_path is None or s.report_path is None:
            s.problem = (
                "No model: press m to open the process model."
                if s.model_path is None
                else "No report: press o to open one."
            )
            self.show()
            return
        s.problem = f"opening {s.report_path} …"
        self.show()
        thermal = (i.thermal, i.temperatures, i.at, i.thermal_dead_band) if i.thermal and i.temperatures else None
        self._work(
            partial(
                workers.open_report,
                s.model_path,
                s.report_path,
                read=i.read,
                cycles=i.cycles,
                solve=SolveOptions(s.optimizer, i.seed, None, i.objective if s.optimizer == "exact" else None),
                db=i.store,
                current=i.current,
                thermal=thermal,
                link=i.link,
                insecure=i.insecure,
            ),
            "open",
        )

    def start_thermal(self) -> None:
        """The saved thermal model's drift over the temperature log, when both are given."""
        panel, i = self.app.query_one(ThermalPanel), self.state.inputs
        if i.thermal is None or i.temperatures is None:
            missing = "--thermal MODEL.json" if i.thermal is None else "--temperatures LOG"
            panel.not_available(f"no thermal model and log given ({missing})")
            return
        panel.not_available(f"predicting drift from {i.temperatures} …")
        self._work(partial(workers.drift, i.thermal, i.temperatures), "thermal")

    def compare(self) -> None:
        """Compare every optimiser on the cycle on screen, in the compare tab."""
        c = self.state.current()
        if c is None:
            self.app.notify("open a report first (o)", severity="warning")
            return
        trials, seed = self.state.inputs.trials, self.state.inputs.seed
        self.app.query_one(TabbedContent).active = "compare"
        self.app.query_one(ComparePanel).progress(0, 1 + len(DEFAULT_METHODS) * trials, "exact")
        # the problem correct solves (guard band, cumulative bounds, costs, fixed registers): exact = the correction
        self._work(partial(workers.compare, self.app, c.posed.guarded, trials, seed), "compare")

    def capability(self) -> None:
        """Capability per stored dimension (``setupfix spc`` of the history store), over the screen."""
        i = self.state.inputs
        if i.store is None:
            self.app.notify(
                "no history store given: start with --db STORE (capability is computed from the stored measurements)",
                title="capability",
                severity="warning",
                timeout=8,
            )
            return
        self.app.notify(f"computing capability from {i.db} …", timeout=3)
        self._work(partial(workers.capability, i.store), "capability")

    def diagnose(self) -> None:
        """Diagnose the series: the history store, else the reports in the current (or watched) folder."""
        s, i = self.state, self.state.inputs
        self.app.query_one(TabbedContent).active = "history"
        if s.model_path is None or s.series_source() == "":
            self.app.notify("open a model and a report first", severity="warning")
            return
        self.app.query_one(HistoryPanel).status(f"diagnosing the reports in {s.series_source()} …")
        source = i.store or Path(s.series_source())
        self._work(partial(workers.diagnose, s.model_path, source, i.process, i.factors), "diagnose")

    def report_picked(self, path: Path | None) -> None:
        """The report (or the folder to watch) the operator picked; None: none."""
        if path is None:
            return
        if path.is_dir():
            self.state.report_path = None
            self.watch(path)
            return
        self.state.folder_watch = None
        self.state.report_path = path
        self.run()

    def model_picked(self, path: Path | None) -> None:
        """The process model the operator picked (None: none): the report is corrected again with it."""
        if path is not None:
            self.state.model_path = path
            self.run()

    def export(self) -> None:
        """The export confirmation of the cycle on screen; what the operator confirms is written."""
        opened = self.state.opened
        if opened is None or not opened.corrections:
            self.app.notify("nothing to export: open a report that matches the model first", severity="warning")
            return
        # A controller program holds one correction: the cycle on screen ([ ] changes it).
        s = self.state
        cycle = s.part_index
        # the format and file last written are offered again (the screen asks before overwriting the file)
        self.app.push_screen(
            ExportScreen(
                CONTROLLERS,
                preview(opened, cycle),
                s.export_path or s.inputs.offsets,
                rename=export_name,
                controller=s.export_controller,
            ),
            partial(self._export_confirmed, opened, cycle),
        )

    def _export_confirmed(self, opened: OpenedReport, cycle: int, request: ExportRequest | None) -> None:
        notify, i = self.app.notify, self.state.inputs
        if request is None:
            notify("export cancelled", timeout=3)
            return
        try:
            exported = write_offsets(request, opened, cycle)
        except SetupfixError as exc:
            notify(str(exc), title="export failed", severity="error", timeout=12)
            return
        self.state.exported(request.controller, request.path)
        program = "" if exported.program_number is None else f" (program {exported.program_number})"
        notify(f"wrote {request.controller} offsets{program} to {request.path}", title="export")
        if i.store is not None:
            try:  # exactly what was written: its rows, and the cycles it holds
                added = record_applied(i.store, exported, opened.corrections)
            except SetupfixError as exc:
                notify(str(exc), title="history store", severity="error", timeout=12)
                return
            notify(f"recorded {added} register change(s) as applied in {i.db}", title="history")

    # ------------------------------------------------------------------ send to machine (w)
    def send(self) -> None:
        """The dry-run diff of the cycle on screen from the control (``--link``); then two confirmations."""
        c, i = self.state.current(), self.state.inputs
        if i.link is None:
            self.app.notify(
                "no machine link given: start with --link LINK.toml to send to the control",
                title="send to machine",
                severity="warning",
                timeout=8,
            )
            return
        if c is None or self.state.opened is None:
            self.app.notify("nothing to send: open a report that matches the model first", severity="warning")
            return
        self.app.notify(f"reading the control ({i.link}) …", title="send to machine", timeout=3)
        current = self.state.opened.current
        self._work(partial(workers.send_plan, c, current, i.link, insecure=i.insecure), "send-plan")

    def _send_planned(self, wp: WritePlan) -> None:
        self.app.push_screen(SendScreen(wp), partial(self._send_first_yes, wp))

    def _send_first_yes(self, wp: WritePlan, go: bool | None) -> None:
        if not go:
            self.app.notify("nothing sent", title="send to machine", timeout=3)
            return
        text = question(wp, self.operator(), self.state.inputs.store is not None)
        self.app.push_screen(ConfirmScreen(text, yes="Write (y)", no="No (n)"), partial(self._send_confirmed, wp))

    def _send_confirmed(self, wp: WritePlan, yes: bool | None) -> None:
        i, opened = self.state.inputs, self.state.opened
        if not yes or opened is None or i.link is None:
            self.app.notify("nothing sent", title="send to machine", timeout=3)
            return
        self.state.send_increment = wp.increment
        self.app.notify("writing to the control …", title="send to machine", timeout=3)
        work = partial(workers.send_apply, opened.model, wp.plan, i.link, i.store, insecure=i.insecure)
        self._work(work, "send")

    def operator(self) -> str:
        """Who sends: ``--operator``, else the login name (what the history store records)."""
        return self.state.inputs.operator or login_name()

    def _sent(self, result: WriteOutcome) -> None:
        line = outcome_line(result, self.operator(), self.state.send_increment)
        self.state.send_line = line
        self.app.notify(
            line, title="send to machine", severity="information" if result.exit_status == 0 else "error", timeout=30
        )

    # ------------------------------------------------------------------ a folder watched
    def watch(self, folder: Path) -> None:
        """Watch ``folder``: its newest finished report is opened, now and whenever a newer one lands."""
        self.state.folder_watch = FolderWatch(folder, settle=self.state.inputs.poll_seconds)
        self.app.set_interval(self.state.inputs.poll_seconds, self._poll_folder)
        self._poll_folder()

    def _poll_folder(self) -> None:
        s = self.state
        if s.folder_watch is None:
            return
        path = s.folder_watch.poll()
        for where, why in s.folder_watch.problems:  # named once each, never silently dropped
            self.app.notify(f"{where}: {why}", title="folder", severity="warning", timeout=12)
        if path is not None:
            if s.report_path is not None:
                self.app.notify(f"new report {path.name}", title="folder")
            s.report_path = path
            self.run()
        elif s.report_path is None:
            s.problem = f"watching {s.folder_watch.folder} for a report …"
            self.show()

    # ------------------------------------------------------------------ results
    def worker_changed(self, event: Worker.StateChanged) -> None:
        """The error boundary and the one place results reach the screen."""
        worker, app, s = event.worker, self.app, self.state
        if event.state == WorkerState.ERROR:
            self._failed(worker.name, worker.error)
        elif event.state == WorkerState.CANCELLED and worker.name == "compare":
            app.query_one(ComparePanel).stopped("comparison cancelled")
        elif event.state == WorkerState.SUCCESS:
            if worker.name == "open" and isinstance(worker.result, tuple):
                opened, s.current_problem = worker.result
                if s.current_problem:
                    app.notify(s.current_problem, title="current offsets", severity="warning", timeout=12)
                self._opened(opened)
            elif worker.name == "capability" and isinstance(worker.result, SpcOutcome):
                app.push_screen(CapabilityScreen(worker.result))
            elif worker.name == "compare":
                self._compared(worker.result)
            elif worker.name == "history" and isinstance(worker.result, tuple):
                budgets, notes = worker.result
                app.query_one(HistoryPanel).budgets(budgets, unit=s.unit(), source=str(s.inputs.db))
                for note in notes:
                    app.notify(note, title="history", severity="warning")
            elif worker.name == "diagnose" and isinstance(worker.result, analysis_view.DiagnosisView):
                app.query_one(HistoryPanel).diagnosis(worker.result, source=s.series_source())
            elif worker.name == "send-plan" and isinstance(worker.result, WritePlan):
                self._send_planned(worker.result)
            elif worker.name == "send" and isinstance(worker.result, WriteOutcome):
                self._sent(worker.result)
            elif worker.name == "thermal" and isinstance(worker.result, analysis_view.DriftView):
                app.query_one(ThermalPanel).show(worker.result, source=str(s.inputs.temperatures))

    def _failed(self, what: str, error: BaseException | None) -> None:
        text = str(error) if isinstance(error, SetupfixError) else f"internal error: {type(error).__name__}: {error}"
        self.app.notify(text, title=f"{what} failed", severity="error", timeout=12)
        if what == "open":
            self.state.open_failed(text)
            self.app.sub_title = ""
            self.show()
        elif what == "compare":
            self.app.query_one(ComparePanel).stopped(f"✗ {text}")
        elif what == "thermal":
            self.app.query_one(ThermalPanel).not_available(text)
        elif what in ("history", "diagnose", "capability"):
            self.app.query_one(HistoryPanel).status(f"✗ {text}")
        elif what in ("send-plan", "send"):
            self.state.send_line = f"✗ {text}"

    def _opened(self, opened: OpenedReport) -> None:
        app, i = self.app, self.state.inputs
        # Work started for the previous report must not land on this one.
        app.workers.cancel_group(app, "compare")
        self.state.report_opened(opened)
        app.sub_title = escape(f"{Path(opened.report).name} · {opened.format} · {Path(opened.model.source).name}")
        app.query_one(MatchPanel).show(opened)
        if not opened.corrections:
            app.query_one(TabbedContent).active = "match"
        self.show()
        store = i.store
        if store is not None and not store.exists:  # reading never creates it
            app.query_one(HistoryPanel).status(f"no history store at {i.db} yet: the first export creates it")
        elif store is not None:
            self._work(partial(workers.history, opened.model, store), "history")

    def _compared(self, comparison: object) -> None:
        panel = self.app.query_one(ComparePanel)
        if not isinstance(comparison, Comparison):
            panel.stopped("comparison cancelled")
            return
        c = self.state.current()
        if c is None or comparison.problem is not c.posed.guarded:
            panel.stopped("that comparison was for a previous report: press c to compare this one")
            return
        self.state.comparison = comparison
        panel.show(
            analysis_view.compare_rows(comparison),
            analysis_view.convergence(comparison, 60),
            exact_f1=comparison.exact.margin_after,
            unit=self.state.unit(),
            heading=f"{comparison.trials} seeded trials per method (seed {comparison.seed})"
            + (f" on {c.part.report} {c.part.part}" if c else ""),
        )
