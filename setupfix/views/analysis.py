"""Presentation helpers of the analyses beside a correction: a comparison of optimisers, a drift prediction,
a diagnosis of the series.

Pure functions from pipeline results to plain rows, curves and views, so that the TUI (and any other front
end) shows numbers without computing them; the rows of a correction itself are in
:mod:`setupfix.views.correction`.  Nothing here reads or writes files.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from setupfix.correction.objective import margins as objective_margins
from setupfix.diagnose.terms import PRODUCT, EffectSpec, Series, channel_values
from setupfix.model import PartMeasurement, ProcessModel
from setupfix.thermal.prediction import DriftPrediction
from setupfix.usecases.compare import Comparison
from setupfix.usecases.diagnosis import DiagnoseOutcome, note_text
from setupfix.views.present import verdict_line

__all__ = [
    "convergence",
    "compare_rows",
    "DriftView",
    "drift_view",
    "CycleBudget",
    "cycle_budgets",
    "EffectRow",
    "DiagnosisView",
    "diagnosis_view",
    "register_labels",
    "level_words",
    "assumed_conditions",
    "next_correction_text",
    "MAX_NOTES",
]

#: Notes a diagnosis shows by default (the rest with ``--verbose``).
MAX_NOTES = 5

Array = npt.NDArray[np.float64]


def convergence(comparison: Comparison, width: int = 60) -> dict[str, Array]:
    """Median best-so-far f1 of each method at ``width`` evenly spaced solution counts.

    The counts run from the first one every trial has recorded to the largest final
    count, so every point is a median over all trials (a finished trial keeps its
    final best).

    Returns
    -------
    dict name → ndarray of shape (width,) [model unit]
    """
    out: dict[str, Array] = {}
    for m in comparison.methods:
        hist = [h for h in m.histories if len(h)]
        if not hist:
            continue
        start = max(float(h[0, 0]) for h in hist)
        end = max(float(h[-1, 0]) for h in hist)
        grid = np.linspace(start, max(end, start), width)
        curves = [h[np.searchsorted(h[:, 0], grid, side="right") - 1, 1] for h in hist]
        out[m.optimizer] = np.median(np.vstack(curves), axis=0)
    return out


def compare_rows(comparison: Comparison) -> list[dict[str, Any]]:
    """The comparison table (exact first) with the skipped methods and their reasons."""
    rows = comparison.table()
    for name, reason in comparison.skipped.items():
        rows.append({"optimizer": name, "skipped": reason})
    return rows


@dataclass(frozen=True)
class DriftView:
    """A drift prediction as the thermal panel shows it."""

    method: str
    target: str
    unit: str  #: the thermal model's unit ("" when it does not say)
    latest: float
    latest_time: str
    recent: Array  #: the last samples of the predicted drift, oldest first
    measured_latest: float | None
    samples: int
    notes: tuple[str, ...] = ()

    @property
    def recent_range(self) -> tuple[float, float]:
        """Lowest and highest drift of the recent curve (the sparkline's scale)."""
        return float(np.min(self.recent)), float(np.max(self.recent))


def drift_view(prediction: DriftPrediction, recent: int = 120) -> DriftView:
    """The latest drift and its recent curve (the last ``recent`` samples)."""
    measured = prediction.measured
    m_last = None
    if measured is not None and len(measured) and np.isfinite(measured[-1]):
        m_last = float(measured[-1])
    return DriftView(
        prediction.method,
        prediction.target,
        (prediction.unit or "").replace("um", "µm"),
        prediction.latest,
        prediction.timestamps[-1] if prediction.timestamps else "",
        np.asarray(prediction.drift[-recent:], dtype=float),
        m_last,
        len(prediction.drift),
        tuple(str(n) for n in prediction.notes),
    )


@dataclass(frozen=True)
class CycleBudget:
    """The error budget δ of one measured cycle, as measured (before its correction)."""

    cycle: str
    timestamp: str
    budget: float
    out_of_tolerance: int
    measured: int


def cycle_budgets(model: ProcessModel, parts: Iterable[PartMeasurement]) -> list[CycleBudget]:
    """δ (eq. 8 on the measured deviations) and the out-of-tolerance count of each cycle."""
    lower = np.array([d.lower for d in model.dimensions])
    upper = np.array([d.upper for d in model.dimensions])
    rows = []
    for p in parts:
        m = p.measured
        margins = objective_margins(p.deviation[m], lower[m], upper[m])
        rows.append(
            CycleBudget(
                f"{p.report}:{p.part}" if p.part else p.report,
                p.timestamp or "",
                float(margins.min()) if margins.size else math.nan,
                int((margins < 0).sum()),
                int(m.sum()),
            )
        )
    return rows


@dataclass(frozen=True)
class EffectRow:
    """One effect the diagnosis found."""

    kind: str
    target: str
    estimate: float
    stderr: float
    unit: str
    rms_after: float
    alike: tuple[str, ...]
    source: str = "search"  #: ``search`` (found) or ``declared`` (a declared design factor, ``--factors``)


@dataclass(frozen=True)
class DiagnosisView:
    """A diagnosis as the history panel shows it: residual before/after, effects, walk forward."""

    cycles: int
    unit: str
    before: tuple[float, float, int]  #: residual RMS, max |residual|, out of tolerance — declared model
    after: tuple[float, float, int]  #: the same with the effects found
    effects: tuple[EffectRow, ...]
    walk: tuple[tuple[str, float, float, float, int], ...]  #: name, mean δ, worst δ, RMS, out of tolerance
    next_correction: tuple[tuple[str, float], ...]  #: registers that move, model ID and change
    notes: tuple[str, ...]
    budgets: tuple[CycleBudget, ...]
    walk_centre: tuple[tuple[str, float, float], ...] = ()  #: name, RMS and mean |·| from the tolerance centre
    next_from: str = "augmented"  #: the model the next correction comes from (augmented, ewma, declared)
    held: tuple[str, ...] = ()  #: registers the centre rule holds (model IDs)
    draft: str | None = None  #: a draft model's next correction as said (:func:`draft_next`): no number
    next_text: str = ""  #: the next correction as a person enters it (:func:`next_correction_text`): registers


def register_labels(model: ProcessModel) -> dict[str, str]:
    """What a person types at the controller for each register: ``G54 X`` for a WKS's X component (in a
    one-axis model its axis), ``G54 C`` for its rotation, ``H4`` for a tool length, ``D5`` for a radius.
    Model IDs stay in the JSON; these are for the text a person acts on."""
    out = {}
    for reg in model.registers:
        if reg.kind == "wks":
            out[reg.id] = f"{reg.register} {reg.component or model.axis}"
        else:
            out[reg.id] = reg.register
    return out


def _runs(names: list[str]) -> str:
    """Part names as runs: ``11–18, 20`` for consecutive integers, else listed (at most six, then how many)."""
    if names and all(n.isdigit() for n in names):
        nums = sorted(int(n) for n in names)
        runs, start = [], nums[0]
        for a, b in zip(nums, [*nums[1:], None], strict=True):
            if b is None or b != a + 1:
                runs.append(f"{start}–{a}" if a > start else f"{start}")
                start = b if b is not None else start
        return ", ".join(runs)
    return ", ".join(names[:6]) + (f" and {len(names) - 6} more" if len(names) > 6 else "")


def level_words(spec: EffectSpec, series: Series) -> str | None:
    """A categorical process effect's levels in words with the parts that carry them:
    ``doe_tool_length Long (parts 11–18)``, a product ``… and …``; a numeric log column that is 0 or 1 on
    every part (``long_tool``) as the column on the parts where it is 1; None for other effects."""
    if spec.kind != "process" or spec.channel is None:
        return None
    try:
        values = channel_values(series, spec.channel)
    except KeyError:
        return None
    if "=" not in spec.channel and not np.isin(values, (0.0, 1.0)).all():
        return None
    words = " and ".join(p.replace("=", " ", 1) if "=" in p else p for p in spec.channel.split(PRODUCT))
    ids = list(series.cycles) if series.cycles else [str(k + 1) for k in range(series.n_cycles)]
    on = [ids[k] for k in np.flatnonzero(values != 0)]
    return f"{words} (parts {_runs(on)})" if on else words


def assumed_conditions(outcome: DiagnoseOutcome) -> str | None:
    """The process conditions the next correction assumes: the channels its model's effects follow, at the
    values of the last part (what :func:`~setupfix.diagnose.walk.next_cycle` forecasts with); None when the
    correction follows no channel."""
    d = outcome.diagnosis
    if d.next_from.source != "augmented":
        return None
    s = d.series
    if not s.n_cycles:
        return None
    seen: dict[str, str] = {}
    for e in d.effects:
        ch = e.spec.channel
        if e.kind not in ("process", "thermal") or ch is None or ch in seen:
            continue
        try:
            v = float(channel_values(s, ch)[-1])
        except KeyError:
            continue
        if "=" in ch:
            words = " and ".join(p.replace("=", " ", 1) for p in ch.split(PRODUCT))
            seen[ch] = words if v != 0 else f"not ({words})"
        else:
            seen[ch] = f"{ch} {v:g}"
    if not seen:
        return None
    last = s.cycles[-1] if s.cycles else str(s.n_cycles)
    return f"the next correction assumes the process of part {last}: " + ", ".join(seen.values())


def next_correction_text(model: ProcessModel, moves: Mapping[str, float]) -> str:
    """The next correction as a person enters it: ``G54 X +0.0130, H4 -0.1920`` (``none`` when nothing moves)."""
    labels = register_labels(model)
    return ", ".join(f"{labels.get(k, k)} {v:+.4f}" for k, v in moves.items() if v != 0) or "none"


def draft_next(outcome: DiagnoseOutcome) -> str | None:
    """A draft model's next correction as every door says it: no number and not "none", but why
    (``correct``'s verdict line of the next cycle); None when the model is no draft."""
    if not outcome.draft:
        return None
    cycle = outcome.next_cycle
    why = verdict_line(cycle) if cycle is not None else f"the model {outcome.input.model.source} is a draft"
    return f"no correction, the model is a draft — {why}"


def diagnosis_view(outcome: DiagnoseOutcome) -> DiagnosisView:
    """What the history panel shows of ``setupfix diagnose``'s outcome."""
    d = outcome.diagnosis
    eb, ea = d.error_before, d.error_after
    walk = (
        ()
        if d.walk is None
        else tuple(
            (name, b.mean_budget, b.worst_budget, b.rms, b.out_of_tolerance) for name, b in d.walk.budgets.items()
        )
    )
    return DiagnosisView(
        cycles=d.series.n_cycles,
        unit=d.layout.unit,
        before=(eb.rms, eb.max, eb.out_of_tolerance),
        after=(ea.rms, ea.max, ea.out_of_tolerance),
        effects=tuple(
            EffectRow(e.kind, e.target, e.estimate, e.stderr, e.unit, e.rms_after, tuple(e.alike), e.source)
            for e in d.effects
        ),
        walk=walk,
        next_correction=tuple((k, v) for k, v in outcome.next_correction.items() if v != 0),
        next_text=next_correction_text(outcome.input.model, outcome.next_correction),
        notes=tuple(note_text(n) for n in outcome.notes),
        budgets=tuple(cycle_budgets(outcome.input.model, outcome.input.parts)),
        walk_centre=()
        if d.walk is None
        else tuple((name, b.centre_rms, b.centre_mean_abs) for name, b in d.walk.budgets.items()),
        next_from=d.next_from.source,
        held=() if d.centred is None else tuple(r for r, h in zip(d.layout.register_ids, d.centred, strict=True) if h),
        draft=draft_next(outcome),
    )
