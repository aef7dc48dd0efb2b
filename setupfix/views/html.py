"""One self-contained HTML page for the quality office: the SPC of a store, or one correction.

Pure functions from outcome objects to a page (text): inline SVG charts and inline CSS,
no script, no font, no image or style sheet from elsewhere, so the file opens anywhere
and prints on A4 (``@page`` A4, sections kept whole across pages).

* :func:`spc_page` (``spc --html``): a summary table of every characteristic, then per
  characteristic the tolerance zone with its measured positions, the individuals and
  moving-range charts (limits, rule violations in red, splits dotted) and the
  capability table with the before/after of each split.
* :func:`correction_page` (``correct --html``): per cycle the verdict, the tolerance
  zone of every dimension with its measured and predicted position, the registers,
  the rules and the binding dimensions; with ``history`` (an :class:`SpcOutcome` of the
  same characteristics) the control charts and capability of each dimension too.

Every name from a report or a model is escaped; nothing here reads or writes files.
"""

from __future__ import annotations

import html
import math
from collections.abc import Iterable, Sequence

import numpy as np

from setupfix.correction.numbers import fmt
from setupfix.inputs.stores import StoreRef
from setupfix.spc import MIN_PARTS, NELSON_RULES, Capability
from setupfix.usecases.requests import CorrectOutcome, CycleCorrection
from setupfix.usecases.spc_report import DimensionSpc, SpcOutcome, baseline_warning, interval_text, too_few_text
from setupfix.views.correction import CONFORMANCE_TEXT, SOURCE_TEXT
from setupfix.views.present import format_flags, verdict_label, verdict_line

__all__ = [
    "spc_page",
    "correction_page",
    "control_charts",
    "tolerance_zone",
    "capability_table",
    "dimension_section",
    "PAGE_CSS",
    "page_frame",
    "series_chart",
    "MAX_ZONE_ROWS",
    "MAX_DOTS",
]

#: Dimensions one tolerance-zone chart draws (the table below it lists every one).
MAX_ZONE_ROWS = 400

_BAD = ' class="bad"'

#: Points a chart draws as dots (above: the line alone, flagged points still as dots).
MAX_DOTS = 500

#: Width of every chart's view box (user units; the chart scales to the page).
_W = 720

PAGE_CSS = """
@page { size: A4; margin: 12mm; }
* { box-sizing: border-box; }
body { font-family: "DejaVu Sans", Arial, Helvetica, sans-serif; font-size: 10pt; color: #111; margin: 0 auto;
       max-width: 190mm; padding: 4mm; background: #fff; }
h1 { font-size: 15pt; margin: 0 0 2mm; } h2 { font-size: 12pt; margin: 5mm 0 2mm; }
h3 { font-size: 10.5pt; margin: 3mm 0 1mm; }
table { border-collapse: collapse; width: 100%; margin: 1mm 0 2mm; font-size: 8.5pt; }
th, td { border-bottom: 1px solid #ccc; padding: 1px 4px; text-align: right; white-space: nowrap; }
th:first-child, td:first-child { text-align: left; white-space: normal; }
th { background: #eef; }
section { break-inside: avoid; page-break-inside: avoid; margin-bottom: 4mm; }
svg { width: 100%; height: auto; display: block; }
.verdict { font-size: 12pt; font-weight: bold; padding: 2mm; border: 2px solid #333; }
.apply { border-color: #1a7f37; } .hold { border-color: #9a6700; } .reject { border-color: #cf222e; }
.bad { color: #cf222e; font-weight: bold; } .muted { color: #666; }
ul { margin: 1mm 0; padding-left: 6mm; }
.warning { border-left: 3px solid #9a6700; background: #fff8c5; padding: 1mm 2mm; margin: 1mm 0; }
details.rules summary { cursor: pointer; } .few { color: #9a6700; }
@media print { body { max-width: none; padding: 0; } }
"""


def _e(text: object) -> str:
    return html.escape(str(text), quote=True)


def _n(value: float | None, digits: int = 4, sign: bool = False) -> str:
    return fmt(value, digits, sign=sign)


def page_frame(title: str, body: Iterable[str]) -> str:
    """The pages' frame (head, inline CSS, body) around ``body``; every page of the views uses it."""
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{_e(title)}</title><style>{PAGE_CSS}</style></head>\n<body>\n" + "\n".join(body) + "\n</body></html>\n"
    )


def _scale(low: float, high: float, top: float, bottom: float) -> tuple[float, float]:
    """(a, b) with y = a·v + b mapping [low, high] onto [bottom, top] (padded 8 %)."""
    if not (math.isfinite(low) and math.isfinite(high)) or high <= low:
        centre = low if math.isfinite(low) else 0.0
        low, high = centre - 1e-3, centre + 1e-3
    pad = 0.08 * (high - low)
    low, high = low - pad, high + pad
    a = (top - bottom) / (high - low)
    return a, bottom - a * low


def _hline(y: float, x0: float, x1: float, colour: str, label: str, dash: str = "") -> str:
    dashed = f' stroke-dasharray="{dash}"' if dash else ""
    return (
        f'<line x1="{x0:.1f}" y1="{y:.1f}" x2="{x1:.1f}" y2="{y:.1f}" stroke="{colour}" stroke-width="1"{dashed}/>'
        f'<text x="{x1 + 3:.1f}" y="{y + 3:.1f}" font-size="9" fill="{colour}">{_e(label)}</text>'
    )


def series_chart(
    values: np.ndarray,
    centre: float,
    upper: float,
    lower: float | None,
    labels: tuple[str, str, str],
    flagged: set[int],
    splits: Sequence[int],
    height: int,
    kind: str,
    baseline: int = 0,
    first: int = 0,
    total: int | None = None,
) -> str:
    """One chart of a series: points joined in order, centre line and limits, flagged points red.

    ``values[i]`` belongs to part ``first + i`` of ``total`` (the moving range starts at the second part)."""
    left, right, top, bottom = 46.0, _W - 70.0, 8.0, height - 14.0
    bounds = [centre, upper] + ([lower] if lower is not None else [])
    finite = [v for v in (*values.tolist(), *bounds) if math.isfinite(v)]
    a, b = _scale(min(finite, default=0.0), max(finite, default=1.0), top, bottom)
    n = len(values)
    total = n + first if total is None else total
    step = (right - left) / max(total - 1, 1)
    xs = [left + (first + i) * step for i in range(n)]
    ys = [a * v + b for v in values]
    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {_W} {height}" role="img" '
        f'class="chart {kind}" aria-label="{_e(kind)} chart">',
        f'<rect x="{left}" y="{top}" width="{right - left}" height="{bottom - top}" fill="#fafafa" '
        'stroke="#999" stroke-width="0.5"/>',
    ]
    if 1 < baseline < total:
        parts.append(
            f'<rect x="{left}" y="{top}" width="{(baseline - 1) * step + step / 2:.1f}" '
            f'height="{bottom - top}" fill="#ddf4ff" class="baseline"/>'
        )
    for at in splits:
        x = left + at * step - step / 2
        parts.append(
            f'<line x1="{x:.1f}" y1="{top}" x2="{x:.1f}" y2="{bottom}" stroke="#8250df" '
            'stroke-width="1" stroke-dasharray="2 2"/>'
        )
    if math.isfinite(upper):
        parts.append(_hline(a * upper + b, left, right, "#cf222e", labels[0], "5 3"))
    if math.isfinite(centre):
        parts.append(_hline(a * centre + b, left, right, "#1a7f37", labels[1]))
    if lower is not None and math.isfinite(lower):
        parts.append(_hline(a * lower + b, left, right, "#cf222e", labels[2], "5 3"))
    if n:
        points = " ".join(f"{x:.1f},{y:.1f}" for x, y in zip(xs, ys, strict=True))
        parts.append(f'<polyline points="{points}" fill="none" stroke="#0550ae" stroke-width="1.2"/>')
        dots = n <= MAX_DOTS  # a long series: the line, and dots only where a rule fired
        for i, (x, y) in enumerate(zip(xs, ys, strict=True)):
            if i in flagged:
                parts.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="3.2" fill="#cf222e"/>')
            elif dots:
                parts.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="2.0" fill="#0550ae"/>')
    lo, hi = (bottom - b) / a, (top - b) / a
    parts.append(
        f'<text x="{left - 3}" y="{top + 8}" font-size="8" text-anchor="end">{_n(hi, 4)}</text>'
        f'<text x="{left - 3}" y="{bottom}" font-size="8" text-anchor="end">{_n(lo, 4)}</text>'
    )
    for part in _part_ticks(total):  # part numbers (1-based) along the axis
        x = left + (part - 1) * step
        anchor = "start" if part == 1 else "end" if part == total else "middle"
        parts.append(
            f'<line x1="{x:.1f}" y1="{bottom}" x2="{x:.1f}" y2="{bottom + 3}" stroke="#999" stroke-width="0.5"/>'
            f'<text x="{x:.1f}" y="{height - 2}" font-size="8" text-anchor="{anchor}" class="tick">{part}</text>'
        )
    parts.append("</svg>")
    return "".join(parts)


def _part_ticks(total: int, most: int = 10) -> list[int]:
    """Part numbers to label on a chart's axis: 1, the last, and multiples of a round step (1, 2 or 5 × 10^k)
    between them, at most ``most`` in all, none crowding the last."""
    if total <= 1:
        return [1]
    steps = (m * 10**k for k in range(12) for m in (1, 2, 5))
    step = next(s for s in steps if (total - 1) / s <= most - 1)
    inner = [k for k in range(step, total, step) if k > 1 and total - k >= step / 2]
    return [1, *inner, total]


def control_charts(d: DimensionSpc) -> str:
    """The individuals chart and, below it, the moving-range chart of one characteristic (inline SVG);
    each limit line carries its value, the axis the part numbers."""
    lim = d.limits
    flagged = {i for v in d.violations for i in range(v.first, v.last + 1)}
    splits = [s.at for s in d.splits]
    x_chart = series_chart(
        d.values,
        lim.center,
        lim.ucl,
        lim.lcl,
        (f"UCL {_n(lim.ucl, 4, True)}", f"CL {_n(lim.center, 4, True)}", f"LCL {_n(lim.lcl, 4, True)}"),
        flagged,
        splits,
        170,
        "individuals",
        lim.baseline,
    )
    mr = np.abs(np.diff(d.values))
    mr_chart = series_chart(
        mr,
        lim.mr_center,
        lim.mr_ucl,
        None,
        (f"UCL {_n(lim.mr_ucl, 4)}", f"MR̄ {_n(lim.mr_center, 4)}", ""),
        set(),
        splits,
        90,
        "moving-range",
        first=1,
        total=len(d.values),
    )
    return x_chart + mr_chart


def tolerance_zone(rows: Sequence[tuple[str, float, float, Sequence[float], float | None]], unit: str) -> str:
    """Each dimension's tolerance zone with its measured positions (dots) and a predicted one (diamond).

    ``rows``: (name, lower, upper, measured values, predicted or None), limits and values
    as deviations from nominal.  Each row is scaled to its own zone (lower at the left
    edge of the band, upper at the right), so dimensions of any tolerance share one chart.
    """
    shown = list(rows)[:MAX_ZONE_ROWS]
    row_h, top, name_w = 16, 14, 170.0
    left, right = name_w + 40.0, _W - 40.0
    height = top + row_h * len(shown) + 8
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {_W} {height}" role="img" class="chart zone" '
        'aria-label="tolerance zones">',
        f'<text x="{left}" y="10" font-size="8" fill="#666">lower limit</text>'
        f'<text x="{right}" y="10" font-size="8" fill="#666" text-anchor="end">upper limit [{_e(unit)}]</text>',
    ]
    for k, (name, lower, upper, measured, predicted) in enumerate(shown):
        y = top + k * row_h + row_h / 2
        lo = lower if math.isfinite(lower) else -max(abs(upper), 1e-3)
        hi = upper if math.isfinite(upper) else max(abs(lower), 1e-3)
        span = hi - lo if hi > lo else 1.0

        def x(v: float, lo: float = lo, span: float = span) -> float:
            return left + (right - left) * (min(max((v - lo) / span, -0.12), 1.12))

        out.append(
            f'<text x="{name_w + 34}" y="{y + 3:.1f}" font-size="9" text-anchor="end">{_e(name[:40])}</text>'
            f'<rect x="{left}" y="{y - 5:.1f}" width="{right - left}" height="10" fill="#dafbe1" '
            'stroke="#1a7f37" stroke-width="0.6"/>'
            f'<line x1="{x(0.0):.1f}" y1="{y - 6:.1f}" x2="{x(0.0):.1f}" y2="{y + 6:.1f}" stroke="#555" '
            'stroke-width="0.6"/>'
        )
        for v in measured:
            if math.isfinite(v):
                inside = (not math.isfinite(lower) or v >= lower) and (not math.isfinite(upper) or v <= upper)
                out.append(
                    f'<circle cx="{x(v):.1f}" cy="{y:.1f}" r="2.4" fill="{"#0550ae" if inside else "#cf222e"}" '
                    'fill-opacity="0.7"/>'
                )
        if predicted is not None and math.isfinite(predicted):
            px = x(predicted)
            out.append(
                f'<path d="M{px:.1f} {y - 5:.1f} L{px + 4:.1f} {y:.1f} L{px:.1f} {y + 5:.1f} '
                f'L{px - 4:.1f} {y:.1f} Z" fill="#8250df"/>'
            )
    out.append("</svg>")
    if len(rows) > len(shown):
        out.append(f'<p class="muted">{len(rows) - len(shown)} more dimension(s) in the table below.</p>')
    return "".join(out)


def _cpk_cells(c: Capability) -> str:
    """Cpk and its interval as two cells, the interval flagged "too few parts" below the stated n."""
    few = too_few_text(c)
    flag = f' <span class="few">{_e(few)}</span>' if few else ""
    return f"<td>{_n(c.cpk, 2)}</td><td>{_e(interval_text(c))}{flag}</td>"


def _capability_rows(label: str, c: Capability) -> str:
    return (
        f"<tr><td>{_e(label)}</td><td>{c.n}</td><td>{_n(c.mean, 4, True)}</td><td>{_n(c.sigma_within, 4)}</td>"
        f"<td>{_n(c.sigma_overall, 4)}</td><td>{_n(c.cp, 2)}</td>{_cpk_cells(c)}"
        f"<td>{_n(c.pp, 2)}</td><td>{_n(c.ppk, 2)}</td>"
        f"<td{_BAD if c.out_of_tolerance else ''}>{c.out_of_tolerance}</td></tr>"
    )


_CAP_HEAD = (
    "<tr><th></th><th>n</th><th>mean</th><th>σ within</th><th>σ overall</th><th>Cp</th><th>Cpk</th>"
    "<th>Cpk 95 % CI</th><th>Pp</th><th>Ppk</th><th>out</th></tr>"
)


def capability_table(d: DimensionSpc) -> str:
    """The capability of the whole series, then per split the parts since the previous one against those
    up to the next."""
    table = f'<table class="capability">{_CAP_HEAD}{_capability_rows("all parts", d.capability)}</table>'
    if not d.splits:
        return table
    rows = [
        "<tr><th>split</th><th>n before</th><th>mean before</th><th>Cpk before</th><th>95 % CI</th>"
        "<th>Ppk before</th><th>n after</th><th>mean after</th><th>Cpk after</th><th>95 % CI</th>"
        "<th>Ppk after</th></tr>"
    ]
    for s in d.splits:
        b, a = s.before, s.after
        rows.append(
            f"<tr><td>{_e(s.source)} {_e(s.time)}</td><td>{b.n}</td><td>{_n(b.mean, 4, True)}</td>"
            f"{_cpk_cells(b)}<td>{_n(b.ppk, 2)}</td><td>{a.n}</td><td>{_n(a.mean, 4, True)}</td>"
            f"{_cpk_cells(a)}<td>{_n(a.ppk, 2)}</td></tr>"
        )
    return table + f'<table class="splits">{"".join(rows)}</table>'


def _violations(d: DimensionSpc) -> str:
    """Every Nelson-rule violation, per rule in a collapsible list (``<details>``), none left out."""
    if not d.violations:
        return '<p class="muted">No Nelson rule (1–4) violated.</p>'
    blocks = []
    for rule in sorted({v.rule for v in d.violations}):
        spans = [
            f"part {v.first + 1} ({v.parts[0]})"
            if len(v.parts) == 1
            else f"parts {v.first + 1}–{v.last + 1} ({v.parts[0]} … {v.parts[-1]}, {len(v.parts)} parts)"
            for v in d.violations
            if v.rule == rule
        ]
        blocks.append(
            f'<details class="rules"><summary>rule {rule} ({_e(NELSON_RULES[rule])}): {len(spans)} violation(s)'
            f"</summary><ul>{''.join(f'<li>{_e(t)}</li>' for t in spans)}</ul></details>"
        )
    return "".join(blocks)


def _baseline_warning(d: DimensionSpc) -> str:
    """The warning of a baseline that spans a split or breaks a rule (with the first stable window), or ''."""
    if d.baseline is None or d.baseline.stable:
        return ""
    source = d.splits[0].source if d.splits else "correction"
    return f'<p class="warning baseline">{_e(baseline_warning(d.name, d.baseline, d.parts, source))}</p>'


def dimension_section(d: DimensionSpc) -> str:
    """One characteristic: tolerance zone, control charts, capability and rule violations."""
    zone = tolerance_zone([(d.name, d.lower, d.upper, d.values[-MAX_DOTS:].tolist(), None)], d.unit)
    if len(d.values) > MAX_DOTS:
        zone += f'<p class="muted">Tolerance zone: the last {MAX_DOTS} parts.</p>'

    return (
        f'<section class="dimension"><h3>{_e(d.name)} <span class="muted">limits {_n(d.lower, 3, True)} / '
        f"{_n(d.upper, 3, True)} {_e(d.unit)}, {len(d.values)} part(s)</span></h3>{_baseline_warning(d)}"
        f"{zone}{control_charts(d)}"
        f"{capability_table(d)}{_violations(d)}</section>"
    )


def spc_page(outcome: SpcOutcome, title: str = "setupfix — process capability and control charts") -> str:
    """The whole ``spc --html`` page."""
    head = [
        "<tr><th>dimension</th><th>n</th><th>Cpk</th><th>Cpk 95 % CI</th><th>Ppk</th><th>out</th><th>rules</th></tr>"
    ]
    for d in outcome.dimensions:
        c = d.capability
        rules = ", ".join(str(r) for r in sorted({v.rule for v in d.violations})) or "—"
        head.append(
            f"<tr><td>{_e(d.name)}</td><td>{c.n}</td>{_cpk_cells(c)}<td>{_n(c.ppk, 2)}</td>"
            f"<td>{c.out_of_tolerance}</td><td>{rules}</td></tr>"
        )
    body = [
        f"<h1>{_e(title)}</h1>",
        f"<p>Store {_e(outcome.store)}: {len(outcome.dimensions)} characteristic(s), values as deviations from "
        f"nominal. Control limits from the first {outcome.baseline} parts; σ within = mean moving range / 1.128, "
        "σ overall = sample standard deviation; Cpk interval: Bissell's normal approximation (95 %; A. F. Bissell, "
        f'Applied Statistics 39 (1990) 331–340), flagged "too few parts" below {MIN_PARTS}. Blue band: '
        "the baseline parts; red points: Nelson rule violations; dotted lines: splits (corrections).</p>",
        f'<section><h2>Summary</h2><table class="summary">{"".join(head)}</table></section>',
        *(dimension_section(d) for d in outcome.dimensions),
    ]
    if outcome.notes:
        body.append("<h2>Warnings</h2><ul>" + "".join(f"<li>{_e(n)}</li>" for n in outcome.notes) + "</ul>")
    return page_frame(title, body)


def _cycle_section(pc: CycleCorrection, history: dict[str, DimensionSpc]) -> str:
    rows = pc.dimension_rows()
    unit = pc.model.unit
    label, line = verdict_label(pc), verdict_line(pc)
    said = line if line.startswith(label) else f"{label}: {line}"
    zone = tolerance_zone([(r["name"], r["lower"], r["upper"], [r["deviation"]], r["predicted"]) for r in rows], unit)
    with_u = any(r.get("uncertainty", 0.0) for r in rows)  # U and ISO 14253-1 verdicts only where a U is given
    table = [
        "<tr><th>dimension</th><th>deviation</th><th>lower</th><th>upper</th><th>predicted</th>"
        "<th>margin</th><th>flags</th>"
        + ("<th>U (k = 2)</th><th>ISO 14253-1 before</th><th>after</th>" if with_u else "")
        + "</tr>"
    ]
    for r in rows:
        flags = format_flags(r["flags"])
        verdicts = (
            f"<td>{_n(r['uncertainty'], 4)} ({_e(SOURCE_TEXT.get(r['uncertainty_source'], '—'))})</td>"
            + "".join(
                f"<td{_BAD if r[k] == 'nonconforming' else ''}>{_e(CONFORMANCE_TEXT.get(r[k], r[k]))}</td>"
                for k in ("conformance_before", "conformance_after")
            )
            if with_u
            else ""
        )
        table.append(
            f"<tr><td>{_e(r['name'])}</td><td>{_n(r['deviation'], 4, True)}</td>"
            f"<td>{_n(r['lower'], 3, True)}</td><td>{_n(r['upper'], 3, True)}</td>"
            f"<td>{_n(r['predicted'], 4, True)}</td><td>{_n(r['margin'], 4, True)}</td>"
            f"<td{_BAD if 'out' in r['flags'] else ''}>{_e(flags)}</td>{verdicts}</tr>"
        )
    regs = ["<tr><th>register</th><th>name</th><th>kind</th><th>offset</th><th>change</th><th></th></tr>"]
    for reg in pc.register_rows():
        note = "fixed" if reg["fixed"] else ("at limit" if reg["at_limit"] else "")
        regs.append(
            f"<tr><td>{_e(reg['id'])}</td><td>{_e(reg['register'])}</td><td>{_e(reg['kind'])}</td>"
            f"<td>{_e(reg['offset'])}</td><td>{_n(reg['delta'], 4, True)}</td><td>{note}</td></tr>"
        )
    names = {d.id: d.name for d in pc.model.dimensions}
    rules = "".join(
        f"<li>{_e(r.rule)}: {_e(r.message)}"
        + (
            f" [{_e(', '.join([*r.registers, *(names.get(d, d) for d in r.dimensions)]))}]"
            if r.registers or r.dimensions
            else ""
        )
        + "</li>"
        for r in pc.recommendation.rules
    )
    binding = ", ".join(names.get(b, b) for b in pc.binding) or "none"
    out = [
        f"<section><h2>{_e(pc.part.report)} — part {_e(pc.part.part or '—')}</h2>",
        f'<p class="verdict {_e(pc.verdict)}">{_e(said)}</p>',
        f"<p>Error budget before {_n(pc.margin_before, 4, True)} {_e(unit)}, after "
        f"{_n(pc.margin_after, 4, True)} {_e(unit)}"
        + (  # a triage: the budget above is over the kept set; say what every dimension's is
            f" over the dimensions kept; over every dimension before {_n(pc.margin_all_before, 4, True)} "
            f"{_e(unit)}, after {_n(pc.margin_all_after, 4, True)} {_e(unit)}"
            if pc.given_up
            else ""
        )
        + f"; binding dimensions: {_e(binding)}.</p></section>",
        f"<section><h3>Tolerance zones: measured (dot) and predicted after the correction (diamond)</h3>{zone}"
        "</section>",
        f'<section><h3>Registers [{_e(unit)}]</h3><table class="registers">{"".join(regs)}</table></section>',
        f"<section><h3>Rules</h3><ul>{rules or '<li>none</li>'}</ul></section>",
        f'<h3>Dimensions</h3><table class="dimensions">{"".join(table)}</table>',
    ]
    zones = [r for r in rows if "zone_position" in r]  # as a CMM prints a position: its diameter
    if zones:
        out.append(
            f"<h3>Position zones as a CMM prints them (⌀ = 2 × the radial distance) [{_e(unit)}]</h3>"
            '<table class="zones"><tr><th>zone</th><th>measured ⌀</th><th>predicted ⌀</th><th>tolerance ⌀</th>'
            "<th>margin (radial)</th></tr>"
            + "".join(
                f"<tr><td>{_e(r['name'])}</td><td>{_n(r['zone_position'], 4)}</td>"
                f"<td>{_n(r['zone_position_predicted'], 4)}</td><td>{_n(r['zone_diameter'], 4)}</td>"
                f"<td>{_n(r['margin'], 4, True)}</td></tr>"
                for r in zones
            )
            + "</table>"
        )
    if pc.notes:
        out.append("<ul>" + "".join(f"<li>{_e(n)}</li>" for n in pc.notes) + "</ul>")
    charted = [history[r["name"]] for r in rows if r["name"] in history]
    if charted:
        out.append("<h2>Process history of these dimensions</h2>")
        out += [dimension_section(d) for d in charted]
    return "\n".join(out)


def correction_page(
    outcome: CorrectOutcome | CycleCorrection,
    history: SpcOutcome | None = None,
    title: str = "setupfix — setup correction",
) -> str:
    """The ``correct --html`` page: per cycle the verdict, tolerance zones with measured and predicted
    positions, registers, rules and binding dimensions; with ``history`` (the SPC of the store) the
    control charts and capability of every dimension the store holds."""
    cycles = outcome.cycles if isinstance(outcome, CorrectOutcome) else (outcome,)
    known = {d.name: d for d in history.dimensions} if history is not None else {}
    body = [f"<h1>{_e(title)}</h1>"]
    if isinstance(outcome, CorrectOutcome):
        body.append(
            f"<p>Report {_e(outcome.report)} ({_e(outcome.format)}, sha256 {_e(outcome.sha256[:16])}…), "
            f"{len(cycles)} cycle(s).</p>"
        )
        body += [f'<p class="muted">{_e(n)}</p>' for n in outcome.notes]
    body += [_cycle_section(pc, known) for pc in cycles]
    return page_frame(title, body)


def write_correction_page(outcome: CorrectOutcome, target: str, store: StoreRef | None = None) -> None:
    """``correct --html``: :func:`correction_page` written atomically to ``target`` (``-``: standard output).

    With ``store`` (``correct --store``: a file or a server, for its machine) the page also holds the
    control charts and capability of the report's dimensions from the stored series.
    """
    from setupfix.outputs.writers import write_text
    from setupfix.usecases.spc_report import SpcRequest, spc_report

    history = None
    if store is not None and store.exists and outcome.cycles:
        model = outcome.cycles[0].model
        names = tuple(dict.fromkeys(d.name for d in model.dimensions))
        with store.for_model(model).open() as opened:
            history = spc_report(opened, SpcRequest(dimensions=names))
    write_text(target, correction_page(outcome, history))
