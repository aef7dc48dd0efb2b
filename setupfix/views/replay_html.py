"""The ``replay --html`` page: what happened next to what the rule set would have done.

One self-contained page in the frame of :mod:`setupfix.views.html` (inline SVG and CSS, no
script, prints on A4): the assumption stated first, the side-by-side table, the model's
walk-forward error, the grid ranked by its stated criterion, then for each dimension (those
with the most values out of tolerance first) the measured series and the replayed one on the
same scale, tolerance limits labelled, corrections dotted, values out of tolerance red.
"""

from __future__ import annotations

import html
import math

import numpy as np

from setupfix.usecases.replay import ASSUMPTION, CRITERION, ReplayOutcome, ReplayScore
from setupfix.views.html import page_frame, series_chart

__all__ = ["replay_page", "MAX_DIMENSIONS"]

#: Dimensions the page charts (the table lists every one).
MAX_DIMENSIONS = 12


def _e(text: object) -> str:
    return html.escape(str(text), quote=True)


def _n(value: float, digits: int = 4) -> str:
    return f"{value:+.{digits}f}" if math.isfinite(value) else "—"


def _cpk(value: float) -> str:
    return f"{value:.2f}" if math.isfinite(value) else "—"


def _rules(outcome_rules: dict[str, object]) -> str:
    return ", ".join(f"{k} = {v}" for k, v in outcome_rules.items() if v is not None)


def _side(label: str, a: ReplayScore, b: ReplayScore, unit: str) -> str:
    low_a = min(a.cpk.values(), default=math.nan)
    low_b = min(b.cpk.values(), default=math.nan)
    rows = [
        ("values out of tolerance", a.out_of_tolerance, b.out_of_tolerance),
        ("parts at risk (ISO 14253-1)", a.parts_at_risk, b.parts_at_risk),
        ("corrections", a.corrections, b.corrections),
        (f"total correction [{unit}]", f"{a.correction_size:.4f}", f"{b.correction_size:.4f}"),
        ("lowest Cpk", _cpk(low_a), _cpk(low_b)),
    ]
    body = "".join(f"<tr><td>{_e(k)}</td><td>{_e(x)}</td><td>{_e(y)}</td></tr>" for k, x, y in rows)
    return f'<table class="replay-summary"><tr><th></th><th>happened</th><th>{_e(label)}</th></tr>{body}</table>'


def _chart(values: np.ndarray, lower: float, upper: float, moves: list[int], kind: str) -> str:
    out = {
        i for i, v in enumerate(values.tolist()) if math.isfinite(v) and ((v < lower) or (v > upper))
    }  # red: out of tolerance
    centre = (lower + upper) / 2 if math.isfinite(lower) and math.isfinite(upper) else 0.0
    labels = (f"USL {_n(upper)}", f"middle {_n(centre)}", f"LSL {_n(lower)}")
    lo = lower if math.isfinite(lower) else None
    return series_chart(values, centre, upper, lo, labels, out, moves, 130, kind)


def replay_page(outcome: ReplayOutcome, title: str = "setupfix — replay of a rule set over the history") -> str:
    """The whole page (text)."""
    a, b = outcome.actual, outcome.replayed
    body = [
        f"<h1>{_e(title)}</h1>",
        f'<p class="warning">{_e(ASSUMPTION)}.</p>',
        f"<p>Store {_e(outcome.store)}, machine {_e(outcome.machine)}: {len(outcome.parts)} parts in time order, "
        f"{len(outcome.dimensions)} dimensions, replayed under <b>{_e(_rules(outcome.rules.to_json()))}</b>. "
        "Parts at risk: a dimension not proven conforming (ISO 14253-1, the model's U; with no U, out of "
        "tolerance). A correction: a part after which some register moved.</p>",
        f"<section><h2>What happened and what the rules would have done</h2>{_side('replayed', a, b, outcome.unit)}"
        "</section>",
    ]
    if outcome.walk_error is not None:
        cells = "".join(f"<tr><td>{_e(k)}</td><td>{v:.4f}</td></tr>" for k, v in outcome.walk_error.items())
        body.append(
            "<section><h2>The model's walk-forward error</h2><p>RMS distance to the tolerance centre each "
            f"controller of the diagnosis reaches over this history [{_e(outcome.unit)}]: the replay is as good "
            f'as the declared model.</p><table class="walk"><tr><th>controller</th><th>RMS</th></tr>{cells}'
            "</table></section>"
        )
    if outcome.grid:
        head = (
            "<tr><th>rules</th><th>out of tolerance</th><th>parts at risk</th><th>corrections</th>"
            f"<th>total [{_e(outcome.unit)}]</th></tr>"
        )
        rows = []
        for i, g in enumerate(outcome.grid):
            mark = ' class="best"' if i == outcome.best else ""
            s = g.score
            rows.append(
                f"<tr{mark}><td>{_e(_rules(g.rules.to_json()))}{' (best)' if mark else ''}</td>"
                f"<td>{s.out_of_tolerance}</td><td>{s.parts_at_risk}</td><td>{s.corrections}</td>"
                f"<td>{s.correction_size:.4f}</td></tr>"
            )
        body.append(
            f"<section><h2>Grid</h2><p>Best: {_e(CRITERION)}.</p>"
            f'<details class="grid" open><summary>{len(outcome.grid)} rule sets</summary>'
            f'<table class="grid">{head}{"".join(rows)}</table></details></section>'
        )
    measured, replayed = outcome.measured, outcome.trace.deviation
    actual_moves = [int(i) + 1 for i in np.flatnonzero(np.any(np.diff(outcome.actual_applied, axis=0) != 0, axis=1))]
    rule_moves = [int(i) + 1 for i in np.flatnonzero(np.any(outcome.trace.moves[:-1] != 0, axis=1))]
    with np.errstate(invalid="ignore"):
        out_a = ((measured < outcome.lower) | (measured > outcome.upper)).sum(axis=0)
        out_b = ((replayed < outcome.lower) | (replayed > outcome.upper)).sum(axis=0)
    order = sorted(range(len(outcome.dimensions)), key=lambda q: (-int(out_a[q]), -int(out_b[q]), q))
    table = ["<tr><th>dimension</th><th>out, happened</th><th>out, replayed</th><th>Cpk</th><th>Cpk replayed</th></tr>"]
    for q in order:
        name = outcome.dimensions[q]
        table.append(
            f"<tr><td>{_e(name)}</td><td>{int(out_a[q])}</td><td>{int(out_b[q])}</td>"
            f"<td>{_cpk(a.cpk.get(name, math.nan))}</td><td>{_cpk(b.cpk.get(name, math.nan))}</td></tr>"
        )
    body.append(f'<section><h2>Per dimension</h2><table class="dimensions">{"".join(table)}</table></section>')
    for q in order[:MAX_DIMENSIONS]:
        lo, up = float(outcome.lower[q]), float(outcome.upper[q])
        body.append(
            f"<section><h3>{_e(outcome.dimensions[q])} [{_e(outcome.unit)}]</h3>"
            f'<p class="muted">happened (dotted: corrections made)</p>'
            f"{_chart(measured[:, q], lo, up, actual_moves, 'replay-before')}"
            f'<p class="muted">replayed (dotted: the rule set\'s corrections)</p>'
            f"{_chart(replayed[:, q], lo, up, rule_moves, 'replay-after')}</section>"
        )
    if len(order) > MAX_DIMENSIONS:
        body.append(f'<p class="muted">{len(order) - MAX_DIMENSIONS} more dimension(s) in the table above.</p>')
    if outcome.notes:
        body.append("<h2>Warnings</h2><ul>" + "".join(f"<li>{_e(n)}</li>" for n in outcome.notes) + "</ul>")
    return page_frame(title, body)
