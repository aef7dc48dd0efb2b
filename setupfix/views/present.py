"""Presentation shared by the CLI and the TUI: number formatting and text tables.

The JSON contract is built by :mod:`setupfix.usecases.contract`.

Pure functions from outcome objects to text or JSON-ready dicts; nothing here prints
or reads files.  Typed notes (:class:`~setupfix.core.errors.Note`) become text only here.
"""

from __future__ import annotations

import textwrap
from typing import Any

import numpy as np

from setupfix.correction.numbers import fmt
from setupfix.correction.offsets import grid_decimals
from setupfix.correction.recommend import stopped_where
from setupfix.correction.relation import RelationMatrices
from setupfix.correction.safety import short_list
from setupfix.usecases.batch_records import BatchSummary
from setupfix.usecases.compare import Comparison
from setupfix.usecases.contract import note_lines, one_line
from setupfix.usecases.requests import CycleCorrection
from setupfix.views.correction import conformance_lines

#: Names a line of the text output lists before "… and N more" (alarms name fewer; the JSON every one).
TEXT_LIST = 30


def format_number(value: float, digits: int = 4) -> str:
    """``+0.0123`` (never ``-0.0000``: :func:`~setupfix.correction.numbers.fmt`); an em dash if missing."""
    return fmt(value, digits, sign=True)


_FLAG_TEXT = {
    "out": "OUT after",
    "out_before": "out before",
    "binding": "◀ binding",
    "given_up": "given up",
    "rejected": "REJECT",
    "guard": "in guard band",
}


def format_flags(flags: list[str]) -> str:
    """Dimension flags as short words for the table (``OUT after``, ``◀ binding``, …)."""
    return ", ".join(_FLAG_TEXT.get(f, f) for f in flags)


def verdict_label(pc: CycleCorrection) -> str:
    """The verdict as shown: APPLY, HOLD, REJECT, or NOT SOLVED for a stopped solve with nothing proven
    (its JSON ``verdict`` stays ``hold``, with ``"solved": false``); a correction from a stopped solve
    says so: ``APPLY (STOPPED: work limit in the leximin stage)``."""
    if not pc.solved:
        return "NOT SOLVED"
    stopped = stopped_where(pc.result)
    return f"{pc.verdict.upper()} (STOPPED: {stopped})" if stopped else pc.verdict.upper()


def verdict_line(pc: CycleCorrection) -> str:
    """One line saying what to do: APPLY / HOLD / REJECT / NOT SOLVED and why."""
    rec = pc.recommendation
    if rec.alarm:  # reject, or a setup error held
        return rec.alarm
    if not rec.solved:
        why = next(r.message for r in rec.rules if r.rule == "not_solved")
        return f"leave the offsets as they are and correct again — {why}"
    if rec.verdict == "hold":
        default = (
            "no change needed"
            if pc.margin_after >= 0
            else "no setup correction improves it: out-of-tolerance dimensions need the NC program or the process"
        )
        why = next((r.message for r in rec.rules if r.rule in ("dead_band", "no_harm")), default)
        return f"HOLD: leave the offsets as they are ({why})"
    stopped = next((r.message for r in rec.rules if r.rule == "stopped"), "")
    return f"APPLY the corrections below ({stopped})" if stopped else "APPLY the corrections below"


def zone_lines(rows: list[dict[str, Any]], unit: str) -> list[str]:
    """The position zones of ``rows`` (:meth:`CycleCorrection.dimension_rows`) as a CMM prints them:
    the diameter 2‖δ‖ measured and predicted against the zone's diameter, beside the radial margin."""
    zones = [row for row in rows if "zone_position" in row]
    if not zones:
        return []
    w = max(len(one_line(row["name"])) for row in zones) + 2
    lines = [
        "",
        f"position zones as a CMM prints them (⌀ = 2 × the radial distance above; the margin stays radial) [{unit}]:",
    ]
    for row in zones:
        lines.append(
            f"  {one_line(row['name']):<{w}}measured ⌀{fmt(row['zone_position'], 4)}  predicted "
            f"⌀{fmt(row['zone_position_predicted'], 4)}  tolerance ⌀{fmt(row['zone_diameter'], 4)}  "
            f"margin {fmt(row['margin'], 4, sign=True)}"
        )
    return lines


def format_correction(pc: CycleCorrection) -> str:
    """Verdict, per-dimension table with flags, every register, the thermal feed-forward, budgets,
    binding dimensions, rules and notes."""
    r = pc.result
    unit = pc.model.unit
    lines = [
        f"{pc.part.report}  part {pc.part.part or '—'}  ({r.optimizer}, {r.status}, {r.seconds * 1000:.0f} ms)",
        f"verdict: {verdict_label(pc)} — {verdict_line(pc)}",
        "",
    ]
    rows = pc.dimension_rows()
    w = max([14] + [len(row["name"]) + 2 for row in rows])
    st = 9 if any(row.get("station") for row in rows) else 0  # station column only for fixtures
    head = (
        f"{'station':<{st}}"[:st]
        + f"{'dimension':<{w}}{'deviation':>11}{'lower':>9}{'upper':>9}{'predicted':>11}{'margin':>9}  flags"
    )
    lines += [head, "-" * len(head)]
    for row in rows:
        lines.append(
            f"{one_line(row.get('station') or ''):<{st}}"[:st]
            + f"{one_line(row['name']):<{w}}{format_number(row['deviation']):>11}"
            f"{format_number(row['lower'], 3):>9}{format_number(row['upper'], 3):>9}"
            f"{format_number(row['predicted']):>11}{format_number(row['margin']):>9}"
            f"  {format_flags(row['flags'])}".rstrip()
        )
    for did in pc.part.absent:
        dim = next(d for d in pc.model.dimensions if d.id == did)
        lines.append(
            f"{one_line(dim.group or ''):<{st}}"[:st]
            + f"{one_line(dim.name):<{w}}{'absent from report: not in the objective':>50}"
        )
    lines += zone_lines(rows, unit)
    lines += conformance_lines(rows, unit)  # U and ISO 14253-1 verdicts, only where a U is given
    model = pc.model
    lines += [
        "",
        f"corrections [{unit}], axis {model.axis}:"
        if not model.multi_axis
        else f"corrections [{unit}; a rotation .C in degrees], per register component:",
    ]
    digits = {reg.id: grid_decimals(model.resolution_of(reg)) for reg in model.registers}
    width = max([6] + [len(reg.id) for reg in model.registers])
    for reg in pc.register_rows():
        note = "fixed" if reg["fixed"] else ("at limit" if reg["at_limit"] else "")
        lines.append(
            f"  {reg['id']:<{width}} {reg['register']:<10} {fmt(reg['delta'], digits[reg['id']], sign=True)}  "
            f"{reg['offset']:<8} {note}".rstrip()
        )
    if pc.thermal is not None:
        lines.append(pc.thermal.line())
    lines += [
        "",
        f"error budget before {fmt(pc.margin_before, 4, sign=True)} {unit}, after "
        f"{fmt(pc.margin_after, 4, sign=True)} {unit}, bonus {fmt(pc.margin_after - pc.margin_before, 4, sign=True)} "
        f"{unit}; correction norm {fmt(pc.norm, 4)} {unit}",
    ]
    if pc.given_up:  # the budget above is the kept dimensions'; --json's margin_before/after are this one
        lines.append(
            f"error budget over every dimension (those given up included) before "
            f"{fmt(pc.margin_all_before, 4, sign=True)} {unit}, after {fmt(pc.margin_all_after, 4, sign=True)} {unit}"
        )
    if r.bound is not None:
        lines.append(f"upper bound (continuous LP): {fmt(r.bound, 4, sign=True)} {unit}")
    names = {d.id: one_line(d.name) for d in pc.model.dimensions}
    if pc.binding:
        lines.append("binding (what stops a better correction): " + ", ".join(names[b] for b in pc.binding))
    if pc.given_up:
        lines.append(
            "given up (need the NC program or the process, not the setup): "
            + short_list((names[b] for b in pc.given_up), TEXT_LIST)
        )
    if pc.verdict != "reject":
        lines.append(r.message)
    for rule in pc.rules:
        what = short_list([*rule.registers, *(names.get(d, d) for d in rule.dimensions)], TEXT_LIST)
        lines.append(f"rule {rule.rule}: {rule.message}" + (f" [{what}]" if what else ""))
    lines += note_lines(pc.notes)
    return "\n".join(lines)


def format_matrix(matrix: np.ndarray, rows: list[str], cols: list[str], title: str, width: int = 100) -> str:
    """A labelled matrix like the paper prints them (integers shown without decimals).

    Columns that do not fit in ``width`` characters continue in further blocks, each
    repeating the row labels and headed ``title (columns a–b of n)``.
    """

    def cell(v: float) -> str:
        return f"{int(v)}" if float(v).is_integer() else f"{v:.3g}"

    col_w = max([len(c) for c in cols] + [len(cell(v)) for v in matrix.ravel()] + [2]) + 1
    lead = max([len(r) for r in rows] + [len(title)]) + 1
    per_block = max(1, (width - lead) // col_w)
    blocks = []
    for start in range(0, len(cols), per_block):
        stop = min(start + per_block, len(cols))
        label = title if stop - start == len(cols) else f"{title} (columns {start + 1}–{stop} of {len(cols)})"
        lines = [label] if label != title else []
        lines.append(f"{title:<{lead}}" + "".join(f"{c:>{col_w}}" for c in cols[start:stop]))
        for name, values in zip(rows, matrix, strict=True):
            lines.append(f"{name:<{lead}}" + "".join(f"{cell(v):>{col_w}}" for v in values[start:stop]))
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


#: A matrix with more cells than this is listed by its non-zero entries, not printed as a grid.
DENSE_CELLS = 20_000


def format_sparse(matrix: np.ndarray, rows: list[str], cols: list[str], title: str, width: int = 100) -> str:
    """A large relation matrix as its non-zero entries, column by column (``D17: +F17 −0.5·F3``).

    Linear in the number of non-zero entries (a grid of 10,000 × 10,000 cells is not
    readable, and took minutes and gigabytes to print).
    """
    c, r = np.nonzero(matrix)
    order = np.argsort(r, kind="stable")  # column by column, rows in order within each
    r, c = r[order], c[order]
    head = (
        f"{title}: {len(rows)} × {len(cols)}, {len(r)} non-zero entries; each column with its "
        f"non-zero rows (columns without any: none shown)"
    )
    lines = [head]
    starts = np.flatnonzero(np.r_[True, r[1:] != r[:-1]]) if len(r) else np.zeros(0, dtype=int)
    for begin, end in zip(starts, [*starts[1:], len(r)], strict=True):
        terms = [_term(float(matrix[i, r[begin]]), rows[i]) for i in c[begin:end]]
        lines.append(
            textwrap.fill(f"{cols[r[begin]]}: " + " ".join(terms), width, initial_indent="  ", subsequent_indent="    ")
        )
    return "\n".join(lines)


def _term(value: float, name: str) -> str:
    """``+F3``, ``−0.5·F3``: a weight and what it applies to."""
    one = abs(abs(value) - 1.0) <= 1e-8 + 1e-5  # np.isclose(|value|, 1), without its per-call cost
    return f"{'+' if value > 0 else '−'}{'' if one else f'{abs(value):.4g}·'}{name}"


def format_relations(rm: RelationMatrices, which: list[str], null: np.ndarray, rank: int) -> str:
    blocks = []
    table = {
        "R_MW": (rm.R_MW, rm.machines, rm.wks),
        "R_WF": (rm.R_WF, rm.wks, rm.features),
        "R_TF": (rm.R_TF, rm.tools, rm.features),
        "R_FD": (rm.R_FD, rm.features, rm.dimensions),
        "C": (rm.composite, rm.registers, rm.dimensions),
    }
    for name in which:
        m, r, c = table[name]
        if m.size == 0:
            blocks.append(f"{name}: empty")
            continue
        blocks.append(format_matrix(m, r, c, name) if m.size <= DENSE_CELLS else format_sparse(m, r, c, name))
    regs = rm.registers
    lines = [
        f"composite C = [R_WF·R_FD ; R_TF·R_FD]: {len(regs)} registers × {len(rm.dimensions)} dimensions,",
        f"rank {rank}",
    ]
    if null.shape[0] == 0:
        lines.append("null space: none — every correction moves some dimension")
    else:
        lines.append(f"null space ({null.shape[0]} direction(s)): corrections that move no dimension")
        for vec in null:
            terms = [_term(v, r) for v, r in zip(vec, regs, strict=True) if v != 0]
            lines.append(textwrap.fill(" ".join(terms), 100, initial_indent="  ", subsequent_indent="    "))
    blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def format_batch_summary(summary: BatchSummary, out: str) -> str:
    """Reports, parts, verdicts, failures, skipped files and time of a batch run."""
    verdicts = ", ".join(f"{summary.verdicts.get(v, 0)} {v}" for v in ("apply", "hold", "reject"))
    rate = summary.reports / summary.seconds if summary.seconds > 0 else 0.0
    unsolved = (
        f" ({summary.unsolved} of the holds not solved within the time limit: nothing proven; a "
        "history store does not count them as done)"
        if summary.unsolved
        else ""
    )
    lines = [
        f"{summary.reports} report(s), {summary.parts} part(s): {verdicts}{unsolved}",
        f"{len(summary.failed)} failed, {len(summary.skipped)} skipped; {summary.seconds:.1f} s ({rate:.0f} reports/s)",
        f"offsets written to {out}" if summary.written else f"nothing new: {out} left as it was",
    ]
    for path, reason in summary.skipped:
        if not reason.startswith("still being written"):
            lines.append(f"skipped {path}: {reason}")
    return "\n".join(lines)


def format_comparison(c: Comparison) -> str:
    """The comparison table for the terminal."""
    unit = c.unit
    gap_unit, scale = ("µm", 1000.0) if unit == "mm" else (f"{unit}/1000", 1000.0)
    e = c.exact
    lines = [
        f"{c.report}  part {c.part or '—'}: {c.trials} trials per method, seed {c.seed}",
        f"before correction f1 = {fmt(e.margin_before, 4, sign=True)} {unit}; exact grid optimum f1 = "
        f"{fmt(e.margin_after, 4, sign=True)}, f2 = {fmt(e.norm, 4)}, f = {fmt(e.fitness, 4, sign=True)} "
        f"({e.status}, {e.seconds * 1000:.0f} ms)",
        "",
        f"{'':8}{'f1 [' + unit + ']':^24}{'f2 [' + unit + ']':^24}{'f = 10·f1 − f2':^24}"
        f"{'':>9}{'':>9}{'gap f1 [' + gap_unit + ']':^14}",
        f"{'method':<8}"
        + f"{'best':>8}{'median':>8}{'worst':>8}" * 3
        + f"{'solutions':>10}{'seconds':>8}{'median':>7}{'worst':>7}",
    ]
    lines.append("-" * len(lines[-1]))
    for row in c.table():
        cells = "".join(f"{row[f'{k}_{s}']:>8.4f}" for k in ("f1", "f2", "f") for s in ("best", "median", "worst"))
        lines.append(
            f"{row['optimizer']:<8}{cells}{row['evaluations']:>10.0f}{row['seconds']:>8.3f}"
            f"{row['gap_median'] * scale:>7.1f}{row['gap_worst'] * scale:>7.1f}"
        )
    lines += [
        "",
        "best/median/worst over the trials (best f1 and f largest, best f2 smallest); solutions and "
        "seconds are medians per trial (exact: solver calls); gap = exact f1 − trial f1.",
    ]
    for name, reason in c.skipped.items():
        lines.append(f"skipped {name}: {reason}")
    return "\n".join(lines)
