"""The history side of the rules as a share of the tolerance, for ``correct`` (and every door through it).

``[safety] mean_of`` decides on the mean of the last n parts and ``min_parts`` lets a
register move only after n parts since its last change: both read the history store
(:class:`setupfix.inputs.smoothing.History`); the math is :mod:`setupfix.correction.rules`'s.
Without a store, both say so in a note and are not applied (as ``ewma``).  The report's own
measurement uncertainty enters the guard band through :func:`with_report_uncertainty`.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import numpy.typing as npt

from parsers.timestamps import instant
from setupfix.core.errors import Note, SourceLocation
from setupfix.correction.conformance import report_uncertainty
from setupfix.correction.ewma import Smoothed, shifted_history
from setupfix.correction.pose import PosedProblem
from setupfix.correction.relation import relation_matrices
from setupfix.correction.rules import mean_of_parts, parts_since_change, with_rules
from setupfix.inputs.smoothing import HISTORY, History
from setupfix.model import PartMeasurement, ProcessModel

__all__ = ["mean_smoothed", "parts_since", "with_history_rules", "with_report_uncertainty"]


def _now(part: PartMeasurement) -> np.datetime64 | None:
    if part.timestamp is None or not str(part.timestamp).strip():
        return None
    return np.datetime64(instant(part.timestamp, SourceLocation(part.report)), "ns")


def mean_smoothed(model: ProcessModel, history: History | None, part: PartMeasurement) -> Smoothed | None:
    """``[safety] mean_of`` = n > 1: the part's deviations replaced by the mean of it and the n − 1 parts before.

    The earlier parts are moved by the corrections logged since
    (:func:`setupfix.correction.ewma.shifted_history`); None when ``mean_of`` is 1.
    """
    n = model.safety.mean_of
    if n <= 1:
        return None
    if history is None:
        note = Note(f"mean_of = {n} needs the history store (--store): deviations not averaged", None, "mean_of")
        return Smoothed(part.deviation, 0, 1.0, (note,))
    now = _now(part)
    if now is None:
        return Smoothed(part.deviation, 0, 1.0, (Note("no timestamp in the report: not averaged", None, "mean_of"),))
    rows = shifted_history(
        now,
        history.times,
        history.deviations,
        history.log_times,
        history.log_register,
        history.log_delta,
        history.log_reset,
        relation_matrices(model).composite,
        min(HISTORY, n - 1),
    )
    mean, used = mean_of_parts(part.deviation, rows, n)
    return Smoothed(mean, used, 1.0)


def parts_since(model: ProcessModel, history: History | None, part: PartMeasurement) -> npt.NDArray[np.int64] | None:
    """Parts measured since each register's last change (this one included), or None without history or time."""
    now = _now(part) if history is not None else None
    if history is None or now is None:
        return None
    return parts_since_change(now, history.times, history.log_times, history.log_register, len(model.registers))


def with_history_rules(
    posed: PosedProblem,
    model: ProcessModel,
    history: History | None,
    part: PartMeasurement,
    averaged: Smoothed | None = None,
) -> PosedProblem:
    """:func:`setupfix.correction.rules.with_rules` with the history's parts since each change, and the notes.

    ``averaged``: :func:`mean_smoothed`'s estimate, named in the smoothing rule's message.
    """
    s = model.safety
    since = parts_since(model, history, part)
    notes = posed.notes
    if since is None and (s.min_parts > 1 or any((r.policy.min_parts or 1) > 1 for r in model.registers)):
        what = "the history store (--store)" if history is None else "the report's timestamp"
        notes = (*notes, Note(f"min_parts needs {what}: every register may move", None, "min_parts"))
    effects = posed.effects
    if averaged is not None and averaged.used:
        said = f"deviations: the mean of this part and the {averaged.used} part(s) before it (mean_of = {s.mean_of})"
        effects = tuple(dataclasses.replace(e, message=said) if e.rule == "ewma" else e for e in effects)
    if notes is not posed.notes or effects is not posed.effects:
        posed = dataclasses.replace(posed, notes=notes, effects=effects)
    return with_rules(posed, model, since)


def with_report_uncertainty(model: ProcessModel, part: PartMeasurement) -> ProcessModel:
    """The model with the report's own U (k = 2) of each dimension in its safety settings (source "report").

    The same model object when the report gives none.
    """
    given = report_uncertainty(part)
    if given is None:
        return model
    s = model.safety
    values = dict(s.dimension_uncertainty)
    source = dict(s.uncertainty_source)
    for dim, u in zip(model.dimensions, given.tolist(), strict=True):
        if np.isfinite(u):
            values[dim.id] = float(u)
            source[dim.id] = "report"
    safety = dataclasses.replace(s, dimension_uncertainty=values, uncertainty_source=source)
    return dataclasses.replace(model, safety=safety)
