"""``setupfix replay``: what a rule set would have done over a machine's stored history, next to what happened.

The history is read by the one series reader (:func:`setupfix.inputs.series.load_series`:
the store's reports in time order, its corrections log summed into the changes in effect
at each part; reports marked rejected, failed or draft left out unless asked).  The replay
itself is :func:`setupfix.correction.replay.replay_rules`, which applies the rules through
:func:`setupfix.correction.rules.apply_rules`.

Both sides are scored alike (:func:`score`): values out of tolerance, parts at risk (a
dimension not proven conforming by ISO 14253-1 with the model's U: with no U, out of
tolerance), the number of corrections (parts after which some register moved) and their
size (the sum of |change| over registers), and each dimension's Cpk (:func:`setupfix.spc.capability`).

``grid``: every combination of dead band share × gain × mean_of is replayed, and the best is
named under :data:`CRITERION`.

The replay assumes the model; it says so, with the declared model's walk-forward error
over the same history (:func:`setupfix.diagnose.walk.walk_forward`, the diagnosis'
own) where the history is short enough (:data:`WALK_MAX_PARTS`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from setupfix.core.errors import Note, ParameterError, SourceLocation
from setupfix.correction.conformance import conformance_codes, dimension_uncertainty
from setupfix.correction.replay import ReplayTrace, replay_rules
from setupfix.diagnose.walk import walk_forward
from setupfix.inputs.series import load_series
from setupfix.inputs.stores import StoreRef
from setupfix.model import ProcessModel, load_model
from setupfix.model.safety import Rules
from setupfix.spc import capability

__all__ = [
    "ReplayRequest",
    "ReplayScore",
    "ReplayOutcome",
    "GridPoint",
    "replay_history",
    "replay_json",
    "format_replay",
    "score",
    "CRITERION",
    "DEFAULT_GRID",
    "WALK_MAX_PARTS",
    "ASSUMPTION",
]

Array = npt.NDArray[np.float64]

#: How ``--grid`` ranks the rule sets it tries.
CRITERION = (
    "fewest predicted values out of tolerance, then fewest parts at risk, then fewest corrections, "
    "then the smallest total correction"
)
#: The grid ``--grid`` tries without values: dead band share × gain × mean_of.
DEFAULT_GRID: tuple[tuple[float | None, ...], tuple[float, ...], tuple[int, ...]] = (
    (None, 0.05, 0.1, 0.2),
    (0.5, 0.7, 1.0),
    (1, 3, 5),
)
#: Parts above which the walk-forward error is not computed (it refits the model at every part).
WALK_MAX_PARTS = 400
#: What every replay says first.
ASSUMPTION = (
    "the replay assumes the model: each part's deviations minus the corrections applied plus the rule's, "
    "through the model's relation matrices; an error of the model is not in it"
)
_DIGITS = 9


@dataclass(frozen=True)
class ReplayRequest:
    """What ``replay`` runs.

    Attributes
    ----------
    db : str, Path or StoreRef
        The history store (and machine).
    model : str, Path or ProcessModel
    rules : Rules, optional
        The candidate; None: the model's ``[safety]`` rules.
    grid : bool
        Also try :data:`DEFAULT_GRID` (or ``grid_values``) and name the best.
    grid_values : tuple of (dead band shares, gains, mean_of values), optional
    include_excluded : bool
        Take in the reports the store keeps marked.
    walk : bool
        Compute the model's walk-forward error (up to :data:`WALK_MAX_PARTS` parts).
    """

    db: str | Path | StoreRef
    model: str | Path | ProcessModel
    rules: Rules | None = None
    grid: bool = False
    grid_values: tuple[tuple[float | None, ...], tuple[float, ...], tuple[int, ...]] | None = None
    include_excluded: bool = False
    walk: bool = True


@dataclass(frozen=True)
class ReplayScore:
    """One side's outcome: values out of tolerance, parts at risk, corrections, their size, Cpk per dimension."""

    out_of_tolerance: int
    parts_at_risk: int
    corrections: int
    correction_size: float
    cpk: dict[str, float]


@dataclass(frozen=True)
class GridPoint:
    """One rule set of the grid and its replayed score."""

    rules: Rules
    score: ReplayScore


@dataclass(frozen=True, eq=False)
class ReplayOutcome:
    """The replay of one rule set (and the grid, if asked) next to what happened."""

    store: str
    machine: str
    parts: tuple[str, ...]
    dimensions: tuple[str, ...]
    registers: tuple[str, ...]
    lower: Array
    upper: Array
    unit: str
    rules: Rules
    actual: ReplayScore
    replayed: ReplayScore
    measured: Array
    actual_applied: Array
    trace: ReplayTrace
    grid: tuple[GridPoint, ...] = ()
    best: int | None = None
    walk_error: dict[str, float] | None = None
    notes: tuple[Note, ...] = ()
    excluded: int = 0


def score(
    deviation: Array, applied: Array, lower: Array, upper: Array, uncertainty: Array, names: Sequence[str]
) -> ReplayScore:
    """Score a series: values out of tolerance, parts at risk, corrections made, their size, Cpk per dimension.

    deviation : (n_parts, n_dimensions) [unit], NaN unmeasured; applied : (n_parts, n_registers) [unit], the
    changes in effect at each part; lower, upper, uncertainty : (n_dimensions,) [unit].
    A correction is a part after which some register's change differs; its size the sum of |change|.
    """
    d = np.asarray(deviation, dtype=np.float64)
    seen = np.isfinite(d)
    with np.errstate(invalid="ignore"):
        out = seen & ((d < lower[None, :]) | (d > upper[None, :]))
    codes = conformance_codes(d, lower[None, :], upper[None, :], uncertainty[None, :])
    risk = np.any(codes >= 1, axis=1)
    steps = np.diff(np.asarray(applied, dtype=np.float64), axis=0)
    moved = np.any(steps != 0, axis=1)
    cpk = {str(n): capability(d[:, q], float(lower[q]), float(upper[q])).cpk for q, n in enumerate(names)}
    return ReplayScore(int(out.sum()), int(risk.sum()), int(moved.sum()), float(np.abs(steps).sum()), cpk)


def _rank(s: ReplayScore) -> tuple[int, int, int, float]:
    return (s.out_of_tolerance, s.parts_at_risk, s.corrections, round(s.correction_size, 12))


def replay_history(request: ReplayRequest) -> ReplayOutcome:
    """Replay the rule set (and the grid) over the stored history.

    Raises
    ------
    StoreError, ParseError, MatchError
        The store or its reports and log (the series reader's errors).
    ParameterError
        A history of fewer than two parts, or a bad grid.
    """
    model = request.model if isinstance(request.model, ProcessModel) else load_model(request.model)
    ref = StoreRef.of(request.db).for_model(model)
    inp = load_series(model, db=ref, include_excluded=request.include_excluded)
    layout, series = inp.layout, inp.series
    n = series.deviation.shape[0]
    if n < 2:
        raise ParameterError(
            f"replay: the store holds {n} part(s) of machine {ref.machine or 'default'!r}: nothing to replay",
            location=SourceLocation(ref.location),
        )
    rules = request.rules if request.rules is not None else model.safety.rules()
    u, _ = dimension_uncertainty(model)
    order = {d.id: q for q, d in enumerate(model.dimensions)}
    u = np.array([u[order[i]] if i in order else 0.0 for i in layout.dimension_ids])
    names = tuple(_names(model, layout.dimension_ids))
    lower, upper, c = layout.lower, layout.upper, layout.composite
    measured, actual = series.deviation, series.applied

    def run(r: Rules) -> tuple[ReplayTrace, ReplayScore]:
        trace = replay_rules(measured, actual, c, lower, upper, model.resolution, r)
        return trace, score(trace.deviation, trace.applied, lower, upper, u, names)

    trace, replayed = run(rules)
    grid: list[GridPoint] = []
    best = None
    if request.grid:
        shares, gains, means = request.grid_values or DEFAULT_GRID
        for share, gain, mean in itertools.product(shares, gains, means):
            try:
                candidate = replace(rules, dead_band_share=share, gain=gain, mean_of=mean)
            except (ValueError, ParameterError) as exc:
                raise ParameterError(f"replay --grid: {exc}") from None
            grid.append(GridPoint(candidate, run(candidate)[1]))
        best = min(range(len(grid)), key=lambda i: _rank(grid[i].score))
    walk = _walk_error(inp, n) if request.walk else None
    notes = list(inp.notes)
    if walk is not None and walk.get("declared", 0.0) > walk.get("ewma", math.inf):
        notes.append(
            Note(
                f"the declared model tracks this history worse than EWMA (walk-forward RMS {walk['declared']:.4f} "
                f"against {walk['ewma']:.4f} {layout.unit}): an effect it lacks moves the parts, and the replay "
                "does not see it ('setupfix diagnose --db' finds it)",
                kind="replay",
            )
        )
    if walk is None and request.walk:
        notes.append(
            Note(
                f"the model's walk-forward error is not computed over {n} parts (at most {WALK_MAX_PARTS}); "
                "'setupfix diagnose --db' over a shorter span gives it",
                kind="replay",
            )
        )
    return ReplayOutcome(
        ref.location,
        ref.machine or "default",
        tuple(series.cycles),
        names,
        tuple(layout.register_ids),
        lower,
        upper,
        layout.unit,
        rules,
        score(measured, actual, lower, upper, u, names),
        replayed,
        measured,
        actual,
        trace,
        tuple(grid),
        best,
        walk,
        tuple(notes),
        inp.excluded,
    )


def _names(model: ProcessModel, ids: Sequence[str]) -> list[str]:
    known = {d.id: d.name for d in model.dimensions}
    return [known.get(i, i) for i in ids]


def _walk_error(inp: Any, n: int) -> dict[str, float] | None:
    """The walk-forward RMS distance to the tolerance centre per controller (the diagnosis' own walk)."""
    if n > WALK_MAX_PARTS or n < 8:
        return None
    walk = walk_forward(inp.layout, inp.series, declared=inp.declared)
    return {name: float(b.centre_rms) for name, b in walk.budgets.items()}


def _num(value: float) -> float | None:
    return round(float(value), _DIGITS) if math.isfinite(value) else None


def _score_json(s: ReplayScore) -> dict[str, Any]:
    return {
        "out_of_tolerance": s.out_of_tolerance,
        "parts_at_risk": s.parts_at_risk,
        "corrections": s.corrections,
        "correction_size": _num(s.correction_size),
        "cpk": {k: _num(v) for k, v in s.cpk.items()},
    }


def replay_json(outcome: ReplayOutcome) -> dict[str, Any]:
    """``replay --json`` (``../shared/spec/cli-json.md``): parts, actual, replayed, rules; grid and more added."""
    doc: dict[str, Any] = {
        "parts": len(outcome.parts),
        "actual": _score_json(outcome.actual),
        "replayed": _score_json(outcome.replayed),
        "rules": outcome.rules.to_json(),
        "store": outcome.store,
        "machine": outcome.machine,
        "unit": outcome.unit,
        "assumption": ASSUMPTION,
        "walk_forward_centre_rms": None
        if outcome.walk_error is None
        else {k: _num(v) for k, v in outcome.walk_error.items()},
        "excluded_reports": outcome.excluded,
        "warnings": [str(n) for n in outcome.notes],
    }
    if outcome.grid:
        doc["grid"] = [{"rules": g.rules.to_json(), **_score_json(g.score)} for g in outcome.grid]
        doc["best"] = None if outcome.best is None else outcome.grid[outcome.best].rules.to_json()
        doc["criterion"] = CRITERION
    return doc


def _rules_text(r: Rules) -> str:
    return ", ".join(f"{k}={v}" for k, v in r.to_json().items() if v is not None)


def format_replay(outcome: ReplayOutcome) -> str:
    """The text of ``replay``: what happened and what the rules would have done, side by side."""
    a, b = outcome.actual, outcome.replayed
    low_a = min(a.cpk.values(), default=math.nan)
    low_b = min(b.cpk.values(), default=math.nan)
    rows = [
        ("values out of tolerance", str(a.out_of_tolerance), str(b.out_of_tolerance)),
        ("parts at risk (ISO 14253-1)", str(a.parts_at_risk), str(b.parts_at_risk)),
        ("corrections", str(a.corrections), str(b.corrections)),
        (f"total correction [{outcome.unit}]", f"{a.correction_size:.4f}", f"{b.correction_size:.4f}"),
        ("lowest Cpk", _f(low_a), _f(low_b)),
    ]
    lines = [
        f"{outcome.store} ({outcome.machine}): {len(outcome.parts)} parts replayed under {_rules_text(outcome.rules)}",
        f"note: {ASSUMPTION}",
        "",
        f"{'':<30}{'happened':>12}{'replayed':>12}",
        *(f"{k:<30}{x:>12}{y:>12}" for k, x, y in rows),
    ]
    if outcome.walk_error is not None:
        shown = ", ".join(f"{k} {v:.4f}" for k, v in outcome.walk_error.items())
        lines += ["", f"model walk-forward RMS distance to the tolerance centre [{outcome.unit}]: {shown}"]
    if outcome.grid and outcome.best is not None:
        g = outcome.grid[outcome.best]
        lines += [
            "",
            f"grid: {len(outcome.grid)} rule sets; best ({CRITERION}):",
            f"  {_rules_text(g.rules)}: {g.score.out_of_tolerance} out of tolerance, {g.score.parts_at_risk} "
            f"parts at risk, {g.score.corrections} corrections",
        ]
    lines += [f"warning: {n}" for n in outcome.notes]
    return "\n".join(lines)


def _f(value: float) -> str:
    return f"{value:.2f}" if math.isfinite(value) else "—"
