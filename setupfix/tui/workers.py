"""Thread workers: each takes immutable inputs, calls the pipeline and returns its result.

They share no mutable state with the screen; the comparison posts its progress as
messages (``post_message`` is thread-safe) and stops between trials when cancelled.
Exceptions reach :meth:`~setupfix.tui.controller.SessionController.worker_changed`, the error boundary.
"""

from __future__ import annotations

from pathlib import Path

from textual.app import App
from textual.worker import get_current_worker

from setupfix.core.errors import SetupfixError
from setupfix.inputs.stores import StoreRef
from setupfix.inputs.thermal_files import predict_drift
from setupfix.links import open_link
from setupfix.model import ProcessModel, load_model
from setupfix.optimize import CorrectionProblem
from setupfix.tui import session
from setupfix.tui.messages import CompareProgress
from setupfix.tui.session import compare_steps, store_parts
from setupfix.usecases.compare import Comparison
from setupfix.usecases.correct import load_request
from setupfix.usecases.diagnosis import DiagnoseRequest, diagnose_reports
from setupfix.usecases.machine import (
    Plan,
    WriteOutcome,
    WritePlan,
    current_from_link,
    plan_of,
    plan_write,
    write_to_control,
)
from setupfix.usecases.requests import CurrentOffsets, CycleCorrection, CycleOptions, ReadOptions, SolveOptions
from setupfix.usecases.spc_report import SpcOutcome, SpcRequest, spc_report
from setupfix.views import analysis as analysis_view

__all__ = ["open_report", "drift", "compare", "history", "diagnose", "capability", "send_plan", "send_apply"]


def open_report(
    model: Path,
    report: Path,
    *,
    read: ReadOptions,
    cycles: CycleOptions,
    solve: SolveOptions,
    db: StoreRef | None,
    current: Path | None,
    thermal: tuple[Path, Path, str | None, float | None] | None,
    link: Path | None = None,
    insecure: bool = False,
) -> tuple[session.OpenedReport, str]:
    """Thread worker: the request ``correct`` builds from these inputs
    (:func:`~setupfix.usecases.correct.load_request`), the report opened with it, and "" — or, when
    ``current`` does not fit ``model`` (the operator switched to another model), the report opened
    without it and the one-line reason.

    A history store not created yet (the first export creates it) holds no history.  With ``link``
    the current offsets are read from the control (``correct --link``): the plan records them.
    """
    saved, log, at, dead_band = thermal if thermal is not None else (None, None, None, None)
    loaded, problem = load_model(model), ""
    offsets: Path | CurrentOffsets | None = current
    if link is not None:
        with open_link(link, insecure=insecure) as opened:
            offsets = current_from_link(opened, loaded)
    elif current is not None:  # re-read against this model: a mismatch is said, not fatal
        try:
            CurrentOffsets.read(current, loaded)
        except SetupfixError as exc:
            problem, offsets = " ".join(f"--current does not fit {model.name}: {exc}".split()), None
    request = load_request(
        loaded,
        read=read,
        cycles=cycles,
        solve=solve,
        current=offsets,
        store=db if db is not None and db.exists else None,
        thermal=saved,
        temperatures=log,
        at=at,
        thermal_dead_band=dead_band,
    )
    return session.open_report(request, report), problem


def drift(model: Path, log: Path) -> analysis_view.DriftView:
    """Thread worker: the saved thermal model's drift over the log."""
    return analysis_view.drift_view(predict_drift(model, log))


def compare(app: App[None], problem: CorrectionProblem, trials: int, seed: int) -> Comparison | None:
    """Thread worker: the comparison one trial at a time, stoppable between trials."""
    worker = get_current_worker()
    result: Comparison | None = None
    for method, step, steps, comparison in compare_steps(problem, trials=trials, seed=seed):
        if worker.is_cancelled:
            return None
        result = comparison
        app.post_message(CompareProgress(step, steps, method))
    return result


def history(model: ProcessModel, db: StoreRef) -> tuple[list[analysis_view.CycleBudget], list[str]]:
    """Thread worker: the error budget of every cycle in the history store."""
    parts, notes = store_parts(model, db)
    return analysis_view.cycle_budgets(model, parts), notes


def diagnose(
    model: Path, source: Path | StoreRef, process: Path | None = None, factors: tuple[str, ...] = ()
) -> analysis_view.DiagnosisView:
    """Thread worker: ``setupfix diagnose`` over the history store or a folder of reports (and its logs), with
    the process log given (``--process``) joined per part and its declared design factors (``--factors``)."""
    proc = str(process) if process is not None else None
    request = (
        DiagnoseRequest(model, db=source, process=proc, factors=factors)
        if isinstance(source, StoreRef)
        else DiagnoseRequest(model, (source,), process=proc, factors=factors)
    )
    outcome = diagnose_reports(request)
    return analysis_view.diagnosis_view(outcome)


def capability(db: StoreRef) -> SpcOutcome:
    """Thread worker: ``setupfix spc`` of the history store (capability, control charts, rule flags);
    a store that does not exist is an error naming it (never created here)."""
    with db.open() as store:
        return spc_report(store, SpcRequest())


def send_plan(
    cycle: CycleCorrection, current: CurrentOffsets | None, link: Path, *, insecure: bool = False
) -> WritePlan:
    """Thread worker: "send to machine", step 1: the plan of the cycle on screen and its dry-run diff
    (``machine write`` without ``--apply``: the control read, nothing written)."""
    plan = plan_of(cycle, current, cycle.part.report)
    with open_link(link, insecure=insecure) as opened:
        return plan_write(cycle.model, plan, opened)


def send_apply(
    model: ProcessModel, plan: Plan, link: Path, db: StoreRef | None, *, insecure: bool = False
) -> WriteOutcome:
    """Thread worker: "send to machine", confirmed twice: ``machine write --apply`` (the guarded sequence),
    the attempt recorded in the history store with its machine and operator when one is given."""
    with open_link(link, insecure=insecure) as opened:
        if db is None:
            return write_to_control(model, plan, opened, apply=True)
        ref = StoreRef(db.location, db.machine or opened.machine, db.operator).for_model(model)
        with ref.open(existing=False) as store:
            return write_to_control(model, plan, opened, apply=True, store=store)
