"""Human-readable text for the terminal (data only: stdout)."""

from __future__ import annotations

import math

import numpy as np

from setupfix.pipeline.correct import PartCorrection
from setupfix.relation import RelationMatrices


def _num(value: float, digits: int = 4) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "—"
    return f"{value:+.{digits}f}"


def format_correction(pc: PartCorrection) -> str:
    """Per-dimension table, corrections by register, budgets and binding dimensions."""
    r = pc.result
    unit = pc.model.unit
    lines = [f"{pc.part.report}  part {pc.part.part or '—'}  ({r.optimizer}, {r.status}, {r.seconds * 1000:.0f} ms)", ""]
    binding = set(r.binding)
    rows = pc.dimension_rows()
    st = 9 if any(row.get("station") for row in rows) else 0  # station column only for fixtures
    head = (f"{'station':<{st}}"[:st] + f"{'dimension':<14}{'deviation':>11}{'lower':>9}{'upper':>9}"
            f"{'predicted':>11}{'margin':>9}")
    lines += [head, "-" * len(head)]
    for row in rows:
        flag = "  ◀ binding" if row["id"] in binding else ""
        out = "  OUT" if not (row["lower"] <= row["deviation"] <= row["upper"]) else ""
        lines.append(f"{row.get('station') or '':<{st}}"[:st] + f"{row['name']:<14}{_num(row['deviation']):>11}{_num(row['lower'], 3):>9}"
                     f"{_num(row['upper'], 3):>9}{_num(row['predicted']):>11}{_num(row['margin']):>9}{flag}{out}")
    for did in pc.part.absent:
        dim = next(d for d in pc.model.dimensions if d.id == did)
        name = dim.name
        lines.append(f"{dim.group or '':<{st}}"[:st] + f"{name:<14}{'absent from report: not in the objective':>50}")
    lines += ["", f"corrections [{unit}], axis {pc.model.axis}:"]
    regs = {reg.id: reg for reg in pc.model.registers}
    for rid, delta in pc.corrections.items():
        lines.append(f"  {rid:<6} {regs[rid].register:<10} {delta:+.{_digits(pc)}f}")
    lines += [
        "",
        f"error budget before {r.margin_before:+.4f} {unit}, after {r.margin_after:+.4f} {unit}, "
        f"bonus {r.bonus:+.4f} {unit}; correction norm {r.norm:.4f} {unit}",
    ]
    if r.bound is not None:
        lines.append(f"upper bound (continuous LP): {r.bound:+.4f} {unit}")
    names = {d.id: d.name for d in pc.model.dimensions}
    lines.append("binding (what stops a better correction): " + ", ".join(names[b] for b in r.binding))
    lines.append(r.message)
    lines += pc.warnings
    return "\n".join(lines)


def _digits(pc: PartCorrection) -> int:
    return max(0, math.ceil(-math.log10(pc.model.resolution) - 1e-9))


def format_matrix(matrix: np.ndarray, rows: list[str], cols: list[str], title: str) -> str:
    """A labelled matrix like the paper prints them (integers shown without decimals)."""
    def cell(v: float) -> str:
        return f"{int(v)}" if float(v).is_integer() else f"{v:.3g}"

    width = max([len(c) for c in cols] + [len(cell(v)) for v in matrix.ravel()] + [2]) + 1
    lead = max([len(r) for r in rows] + [len(title)]) + 1
    lines = [f"{title:<{lead}}" + "".join(f"{c:>{width}}" for c in cols)]
    for name, values in zip(rows, matrix):
        lines.append(f"{name:<{lead}}" + "".join(f"{cell(v):>{width}}" for v in values))
    return "\n".join(lines)


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
        blocks.append(format_matrix(m, r, c, name))
    regs = rm.registers
    lines = [f"composite C = [R_WF·R_FD ; R_TF·R_FD]: {len(regs)} registers × {len(rm.dimensions)} dimensions, "
             f"rank {rank}"]
    if null.shape[0] == 0:
        lines.append("null space: none — every correction moves some dimension")
    else:
        lines.append(f"null space ({null.shape[0]} direction(s)): corrections that move no dimension")
        for vec in null:
            terms = [f"{'+' if v > 0 else '−'}{'' if np.isclose(abs(v), 1) else f'{abs(v):.4g}·'}{r}"
                     for v, r in zip(vec, regs) if v != 0]
            lines.append("  " + " ".join(terms))
    blocks.append("\n".join(lines))
    return "\n\n".join(blocks)
