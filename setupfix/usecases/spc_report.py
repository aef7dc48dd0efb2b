"""``setupfix spc``: capability, control charts and rule violations of the series a history store holds.

The stored measurements (:meth:`setupfix.store.Store.measurements`, reference-only rows
left out) become one series per characteristic: the deviation from nominal of every
part, in time order (a part stored twice counts once: the same measurement, by the content
identity of :mod:`setupfix.inputs.duplicates`; reports the store keeps marked rejected, failed
or draft are left out unless asked, and counted).  For each the
engine (:mod:`setupfix.spc`) gives the capability against the characteristic's limits,
the individuals / moving-range chart limits from the first ``baseline`` parts, the
Nelson-rule violations (each naming the parts it covers) and the capability before
and after each split: the times given, or else every applied correction in the store's
log (the parts since the previous split against the parts up to the next one).

The baseline is checked (:func:`setupfix.spc.baseline_check`): a baseline that spans a split
or whose own points break a Nelson rule is warned about, with the first stable window offered.
Every Cpk carries Bissell's 95 % interval; below :data:`setupfix.spc.MIN_PARTS` parts it is
flagged "too few parts".

Renderers (text, JSON, the HTML page of :mod:`setupfix.views.html`) take the
:class:`SpcOutcome`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from parsers.timestamps import instant
from setupfix.core.errors import MatchError, Note, ParameterError, SourceLocation, StoreError
from setupfix.correction.safety import short_list
from setupfix.inputs.duplicates import ContentIndex, content_of, time_ns
from setupfix.inputs.smoothing import excluded_note
from setupfix.model import normalise_name
from setupfix.spc import (
    MIN_PARTS,
    NELSON_RULES,
    BaselineCheck,
    Capability,
    ChartLimits,
    baseline_check,
    capability,
    chart_limits,
    nelson,
    split_capability,
)
from setupfix.store import Store, excluded_reports

__all__ = [
    "SpcRequest",
    "SpcOutcome",
    "DimensionSpc",
    "RuleHit",
    "SplitEffect",
    "spc_report",
    "spc_json",
    "format_spc",
    "capability_json",
    "interval_text",
    "sparkline",
    "capability_rows",
    "CapabilityRow",
    "DEFAULT_BASELINE",
    "baseline_json",
    "baseline_warning",
    "too_few_text",
]

#: Parts the control limits are computed from unless ``--baseline`` says otherwise.
DEFAULT_BASELINE = 20
#: Violations of one rule a text line names before "… and N more" (the JSON names every one).
TEXT_LIST = 12
#: Digits of the numbers in the JSON output.
_DIGITS = 9


@dataclass(frozen=True)
class SpcRequest:
    """What ``spc`` reports on.

    Attributes
    ----------
    since, until : str, optional
        ISO 8601 times: only parts made at or after ``since`` and at or before ``until``.
    dimensions : tuple of str
        Characteristic names (case and runs of blanks ignored); empty: every one stored.
    baseline : int
        Parts the control limits are computed from (the first ones of the series).
    splits : tuple of str
        ISO 8601 times to compare the capability before and after; empty: every applied
        correction of the store's log.
    include_excluded : bool
        Take in the reports the store keeps marked (rejected, failed, draft).
    """

    since: str | None = None
    until: str | None = None
    dimensions: tuple[str, ...] = ()
    baseline: int = DEFAULT_BASELINE
    splits: tuple[str, ...] = ()
    include_excluded: bool = False


@dataclass(frozen=True)
class RuleHit:
    """One Nelson-rule violation: rule number, what it tests, and the parts it covers (first to last)."""

    rule: int
    text: str
    first: int
    last: int
    parts: tuple[str, ...]


@dataclass(frozen=True)
class SplitEffect:
    """Capability before and after one split time (``source``: ``"split"`` or ``"correction"``);
    ``at`` is the index in the series of the first part made after it."""

    time: str
    source: str
    before: Capability
    after: Capability
    at: int


@dataclass(frozen=True, eq=False)
class DimensionSpc:
    """The SPC of one characteristic: its series (deviations, mm), capability, chart and rule violations."""

    name: str
    unit: str
    lower: float
    upper: float
    parts: tuple[str, ...]
    times: tuple[str, ...]
    values: NDArray[np.float64]
    capability: Capability
    limits: ChartLimits
    violations: tuple[RuleHit, ...]
    splits: tuple[SplitEffect, ...]
    baseline: BaselineCheck | None = None


@dataclass(frozen=True, eq=False)
class SpcOutcome:
    """Every characteristic's SPC, the split times used, the notes and the marked reports left out."""

    store: str
    baseline: int
    dimensions: tuple[DimensionSpc, ...]
    splits: tuple[str, ...] = ()
    notes: tuple[Note, ...] = ()
    excluded: int = 0


def _time(text: str | None, where: str) -> datetime | None:
    return None if text is None else instant(text, SourceLocation(where))


def _series(store: Store, request: SpcRequest, notes: list[Note]) -> pd.DataFrame:
    """The stored rows as one series table: characteristic, part, time, value, limits, in time order."""
    rows = store.measurements(include_excluded=request.include_excluded)
    where = f"{store.location}#measurements"
    rows = rows[~rows["reference"].astype(bool)] if "reference" in rows.columns else rows
    if rows.empty:
        left_out = 0 if request.include_excluded else len(excluded_reports(store))
        raise StoreError(
            f"no measurements stored for machine {store.machine!r}"
            + (f" but of {left_out} report(s) marked rejected, failed or draft" if left_out else ""),
            location=SourceLocation(store.location),
            hint="--include-excluded takes them in"
            if left_out
            else "store reports with 'setupfix history import --machine NAME'; "
            "'setupfix history show' lists the machines",
        )
    stamps = rows["timestamp"].fillna("").astype(str).str.strip()
    dated = stamps != ""
    bounded = request.since or request.until or request.splits
    if not dated.all():
        first = rows.loc[~dated, "report"].iloc[0]
        if bounded:
            raise ParameterError(
                f"spc: parts of {first!s} have no timestamp: --since, --until and --split need the time of every part",
                hint="give the reports a timestamp column",
            )
        if dated.any():
            raise ParameterError(
                f"spc: parts of {first!s} have no timestamp while others have one: no order",
                hint="give every report a timestamp, or store them in order without any",
            )
        notes.append(
            Note(
                "no part has a timestamp: the parts are in the order they were stored",
                SourceLocation(where),
                kind="spc",
            )
        )
    frame = pd.DataFrame(
        {
            "characteristic": rows["characteristic"].astype(str).to_numpy(),
            "key": [normalise_name(c) for c in rows["characteristic"].astype(str)],
            "part": rows["part"].fillna("").astype(str).to_numpy(),
            "time": pd.DatetimeIndex([instant(t, SourceLocation(where)) for t in stamps])
            if dated.all()
            else pd.DatetimeIndex([pd.NaT] * len(rows)),
            "stamp": stamps.to_numpy(),
            "value": np.where(rows["deviation"].notna(), rows["deviation"], rows["actual"] - rows["nominal"]),
            "lower": rows["lower"].astype(float).to_numpy(),
            "upper": rows["upper"].astype(float).to_numpy(),
            "unit": rows["unit"].fillna("mm").astype(str).to_numpy(),
            "order": np.arange(len(rows)),
            "sha": rows["report_sha256"].astype(str).to_numpy() if "report_sha256" in rows.columns else "",
        }
    )
    since, until = _time(request.since, "--since"), _time(request.until, "--until")
    if since is not None:
        frame = frame[frame["time"] >= since]
    if until is not None:
        frame = frame[frame["time"] <= until]
    if frame.empty:
        raise ParameterError("spc: no stored part lies between --since and --until")
    # a part stored twice (a report imported again under other bytes, in another format, a name in
    # other case) counts once: the content identity of every door's history, newest import kept
    doubles = _repeated(frame, where)
    if doubles.any():
        notes.append(
            Note(
                f"{int(doubles.sum())} value(s) of parts stored more than once: counted once",
                SourceLocation(where),
                kind="spc",
            )
        )
        frame = frame[~doubles]
    return frame.sort_values(["time", "order"], kind="stable") if dated.all() else frame


def _repeated(frame: pd.DataFrame, where: str) -> NDArray[np.bool_]:
    """The rows of stored parts that repeat a part stored later (the same measurement,
    :func:`setupfix.inputs.duplicates.same_measurement`), each characteristic the later copy holds."""
    groups = list(frame.groupby(["sha", "part", "stamp"], sort=False).indices.items())
    index = ContentIndex()
    kept: list[set[str]] = []
    out = np.zeros(len(frame), dtype=bool)
    keys = frame["key"].to_numpy()
    values = frame["value"].to_numpy(dtype=float)
    for (_, part, stamp), rows in reversed(groups):  # the newest import first: it is the one kept
        when = time_ns(stamp, where) if stamp else None
        c = content_of(str(part), when, {str(keys[r]): float(values[r]) for r in rows})
        j = index.find(c)
        if j is None:
            index.add(c)
            kept.append(set(c.values))
        else:
            out[[r for r in rows if keys[r] in kept[j]]] = True
    return out


def _selected(frame: pd.DataFrame, names: Sequence[str]) -> list[str]:
    """The characteristic keys to report, in first-stored order; an unknown name is refused with the stored ones."""
    keys = list(dict.fromkeys(frame.sort_values("order")["key"]))
    if not names:
        return keys
    wanted = [normalise_name(n) for n in names]
    unknown = [n for n, k in zip(names, wanted, strict=True) if k not in keys]
    if unknown:
        shown = ", ".join(dict.fromkeys(frame["characteristic"]).keys())
        raise MatchError(
            f"spc: no stored characteristic {unknown[0]!r}",
            hint=f"stored: {shown[:300]}{'…' if len(shown) > 300 else ''}",
        )
    return list(dict.fromkeys(wanted))


def _split_times(store: Store, request: SpcRequest) -> tuple[list[datetime], list[str], str]:
    if request.splits:
        times = [instant(t, SourceLocation("--split")) for t in request.splits]
        return times, [t.isoformat() for t in times], "split"
    log = store.corrections("correction")
    stamps = list(dict.fromkeys(str(t) for t in log["timestamp"]))
    where = SourceLocation(f"{store.location}#corrections")
    times = [instant(t, where) for t in stamps]
    return times, [t.isoformat() for t in times], "correction"


def _effects(
    group: pd.DataFrame, splits: list[datetime], labels: list[str], source: str, lower: float, upper: float
) -> tuple[SplitEffect, ...]:
    """Capability of the parts since the previous split against the parts up to the next, for each split."""
    if group["time"].isna().any():
        return ()
    times = group["time"].to_numpy()
    values = group["value"].to_numpy(dtype=float)
    order = sorted(range(len(splits)), key=lambda i: splits[i])
    edges = [np.datetime64(splits[i]) for i in order]
    out = []
    for k, i in enumerate(order):
        start = edges[k - 1] if k else None
        stop = edges[k + 1] if k + 1 < len(edges) else None
        window = np.ones(len(times), dtype=bool)
        if start is not None:
            window &= times >= start
        if stop is not None:
            window &= times < stop
        after = times >= edges[k]
        if not (window & ~after).any() or not (window & after).any():
            continue  # no part on one side: nothing to compare
        before_c, after_c = split_capability(values[window], after[window], lower, upper)
        out.append(SplitEffect(labels[i], source, before_c, after_c, int(np.argmax(after))))
    return tuple(out)


def spc_report(store: Store, request: SpcRequest) -> SpcOutcome:
    """Capability, control charts, Nelson rules and before/after capability of every stored characteristic.

    Raises
    ------
    StoreError
        No measurement stored.
    ParameterError
        A bad time, a baseline below 2, ``machine`` on a store without machines, parts
        without timestamps where times are needed, nothing between ``since`` and ``until``.
    MatchError
        A requested characteristic the store does not hold.
    """
    if request.baseline < 2:
        raise ParameterError(f"spc: --baseline must be at least 2 parts, got {request.baseline}")
    notes: list[Note] = []
    frame = _series(store, request, notes)
    keys = _selected(frame, request.dimensions)
    splits, labels, source = _split_times(store, request)
    dims = []
    for key in keys:
        group = frame[frame["key"] == key]
        last = group.iloc[-1]
        name = str(last["characteristic"])
        lower, upper = float(last["lower"]), float(last["upper"])
        limits_seen = group[["lower", "upper"]].drop_duplicates()
        if len(limits_seen) > 1:
            notes.append(
                Note(
                    f"{name}: its limits changed over the series; the last ones ({lower:g}, {upper:g}) are used",
                    kind="spc",
                )
            )
        values = group["value"].to_numpy(dtype=float)
        parts = tuple(group["part"])
        if len(values) < request.baseline:
            notes.append(
                Note(
                    f"{name}: {len(values)} part(s), fewer than the baseline of {request.baseline}: "
                    "the limits come from all of them",
                    kind="spc",
                )
            )
        limits = chart_limits(values, request.baseline)
        effects = _effects(group, splits, labels, source, lower, upper)
        check = baseline_check(values, request.baseline, _split_indices(group, splits))
        if not check.stable:
            notes.append(Note(baseline_warning(name, check, parts, source), kind="spc"))
        hits = tuple(
            RuleHit(v.rule, NELSON_RULES[v.rule], v.start, v.end, parts[v.start : v.end + 1])
            for v in nelson(values, limits.center, limits.sigma)
        )
        dims.append(
            DimensionSpc(
                name,
                str(last["unit"]),
                lower,
                upper,
                parts,
                tuple(group["stamp"]),
                values,
                capability(values, lower, upper),
                limits,
                hits,
                effects,
                check,
            )
        )
    excluded = 0 if request.include_excluded else len(excluded_reports(store))
    if excluded:
        notes.append(excluded_note(excluded, "the series"))
    return SpcOutcome(store.location, request.baseline, tuple(dims), tuple(labels), tuple(notes), excluded)


def _split_indices(group: pd.DataFrame, splits: list[datetime]) -> list[int]:
    """For each split time, the index of the first part of ``group`` made at or after it (inside the series only)."""
    if group["time"].isna().any() or not splits:
        return []
    times = group["time"].to_numpy()
    at = np.searchsorted(times, np.array([np.datetime64(t) for t in splits], dtype=times.dtype))
    return sorted({int(i) for i in at if 0 < i < len(times)})


def baseline_warning(name: str, check: BaselineCheck, parts: Sequence[str], source: str = "correction") -> str:
    """One line: what is wrong with ``name``'s baseline and the first stable window (or why there is none)."""
    what = []
    if check.splits_inside:
        what.append(f"spans {len(check.splits_inside)} {source}(s) (before parts {_parts(parts, check.splits_inside)})")
    if check.violations:
        rules = sorted({v.rule for v in check.violations})
        what.append(f"breaks Nelson rule {', '.join(str(r) for r in rules)} on its own limits")
    head = f"{name}: the baseline (parts 1–{check.size}) " + " and ".join(what) + ": its control limits are not sound"
    if check.first_stable is not None:
        first = check.first_stable
        return head + (
            f"; the first stable window of {check.size} parts is parts {first + 1}–{first + check.size} "
            f"({parts[first]} … {parts[first + check.size - 1]})"
        )
    if check.longest_free < check.size:
        return head + (
            f"; no stable window of {check.size} parts: at most {check.longest_free} parts in a row lie between "
            f"two {source}s (--baseline {check.longest_free} or fewer may find one)"
        )
    return head + f"; no stable window of {check.size} parts in the {check.searched} tried"


def _parts(parts: Sequence[str], at: Sequence[int]) -> str:
    return short_list([f"{i + 1} ({parts[i]})" for i in at], 4)


def too_few_text(c: Capability) -> str:
    """``"too few parts (n < 30)"`` when ``c`` rests on fewer than :data:`MIN_PARTS` values, else ``""``."""
    return f"too few parts (n < {MIN_PARTS})" if c.too_few and c.n else ""


def baseline_json(check: BaselineCheck | None, parts: Sequence[str]) -> dict[str, Any] | None:
    """The baseline check as JSON: splits inside, the rules its points break, the first stable window."""
    if check is None:
        return None
    first = check.first_stable
    return {
        "parts": check.size,
        "stable": check.stable,
        "splits_inside": [{"first_after": i, "part": parts[i]} for i in check.splits_inside],
        "violations": [
            {"rule": v.rule, "text": NELSON_RULES[v.rule], "first": v.start, "last": v.end} for v in check.violations
        ],
        "first_stable_window": None
        if first is None
        else {"first": first, "last": first + check.size - 1, "parts": [parts[first], parts[first + check.size - 1]]},
        "windows_searched": check.searched,
        "longest_without_split": check.longest_free,
    }


def _num(value: float) -> float | None:
    return round(float(value), _DIGITS) if math.isfinite(value) else None


def capability_json(c: Capability) -> dict[str, Any]:
    """One :class:`~setupfix.spc.Capability` as JSON (NaN as null)."""
    return {
        "n": c.n,
        "mean": _num(c.mean),
        "sigma_within": _num(c.sigma_within),
        "sigma_overall": _num(c.sigma_overall),
        "cp": _num(c.cp),
        "cpk": _num(c.cpk),
        "cpk_ci95": [_num(c.cpk_low), _num(c.cpk_high)],
        "pp": _num(c.pp),
        "ppk": _num(c.ppk),
        "out_of_tolerance": c.out_of_tolerance,
        "too_few_parts": c.too_few,
    }


def spc_json(outcome: SpcOutcome) -> dict[str, Any]:
    """``spc --json``: per characteristic its capability, chart limits, violations and split effects."""
    return {
        "store": outcome.store,
        "baseline": outcome.baseline,
        "min_parts": MIN_PARTS,
        "cpk_interval": "Bissell (1990) normal approximation, 95 %",
        "splits": list(outcome.splits),
        "excluded_reports": outcome.excluded,
        "dimensions": [
            {
                "name": d.name,
                "unit": d.unit,
                "lower": _num(d.lower),
                "upper": _num(d.upper),
                **capability_json(d.capability),
                "chart": {
                    "center": _num(d.limits.center),
                    "sigma": _num(d.limits.sigma),
                    "ucl": _num(d.limits.ucl),
                    "lcl": _num(d.limits.lcl),
                    "mr_center": _num(d.limits.mr_center),
                    "mr_ucl": _num(d.limits.mr_ucl),
                    "baseline": d.limits.baseline,
                },
                "violations": [
                    {"rule": v.rule, "text": v.text, "first": v.first, "last": v.last, "parts": list(v.parts)}
                    for v in d.violations
                ],
                "baseline_check": baseline_json(d.baseline, d.parts),
                "split_effects": [
                    {
                        "time": s.time,
                        "source": s.source,
                        "first_after": s.at,
                        "before": capability_json(s.before),
                        "after": capability_json(s.after),
                    }
                    for s in d.splits
                ],
                "parts": list(d.parts),
                "times": list(d.times),
                "values": [_num(v) for v in d.values],
            }
            for d in outcome.dimensions
        ],
        "warnings": [str(n) for n in outcome.notes],
    }


def _f(value: float, digits: int = 2) -> str:
    return f"{value:.{digits}f}" if math.isfinite(value) else "—"


def interval_text(c: Capability) -> str:
    """The Cpk interval as ``low–high`` (``—`` when undefined)."""
    return f"{_f(c.cpk_low)}–{_f(c.cpk_high)}" if math.isfinite(c.cpk_low) else "—"


def format_spc(outcome: SpcOutcome) -> str:
    """The text table of ``spc``: one line per characteristic, then its rule violations and split effects."""
    width = max([14, *(len(d.name) + 2 for d in outcome.dimensions)])
    head = (
        f"{'dimension':<{width}}{'n':>5}{'mean':>10}{'σ within':>10}{'σ overall':>10}"
        f"{'Cp':>7}{'Cpk':>7}{'Cpk 95 % CI':>15}{'Pp':>7}{'Ppk':>7}{'out':>5}  rules"
    )
    lines = [
        f"{outcome.store}: {len(outcome.dimensions)} characteristic(s); control limits from the first "
        f"{outcome.baseline} part(s); deviations from nominal",
        "",
        head,
        "-" * len(head),
    ]
    for d in outcome.dimensions:
        c = d.capability
        rules = ",".join(str(r) for r in sorted({v.rule for v in d.violations})) or "—"
        ci = interval_text(c)
        lines.append(
            f"{d.name:<{width}}{c.n:>5}{_f(c.mean, 4):>10}{_f(c.sigma_within, 4):>10}"
            f"{_f(c.sigma_overall, 4):>10}{_f(c.cp):>7}{_f(c.cpk):>7}{ci:>15}{_f(c.pp):>7}"
            f"{_f(c.ppk):>7}{c.out_of_tolerance:>5}  {rules}"
        )
    for d in outcome.dimensions:
        for rule in sorted({v.rule for v in d.violations}):
            spans = [
                v.parts[0] if len(v.parts) == 1 else f"{v.parts[0]} … {v.parts[-1]} ({len(v.parts)} parts)"
                for v in d.violations
                if v.rule == rule
            ]
            lines.append(f"{d.name}: rule {rule} ({NELSON_RULES[rule]}): {short_list(spans, TEXT_LIST)}")
    effects = [(d, s) for d in outcome.dimensions for s in d.splits]
    if effects:
        lines += [
            "",
            "capability before → after each split (Cpk [Bissell's 95 % interval], parts since the previous split / "
            f"up to the next; too few: n < {MIN_PARTS}):",
        ]
        for d, s in effects:
            lines.append(
                f"{d.name:<{width}}{s.source} {s.time}: Cpk {_cpk_text(s.before)} → "
                f"{_cpk_text(s.after)}, mean {_f(s.before.mean, 4)} → {_f(s.after.mean, 4)}"
            )
    lines += [f"warning: {n}" for n in outcome.notes]
    return "\n".join(lines)


def _cpk_text(c: Capability) -> str:
    """``Cpk [low–high] (n=…)`` with "too few parts" below :data:`MIN_PARTS`."""
    return f"{_f(c.cpk)} [{interval_text(c)}] (n={c.n}{', too few' if c.too_few and c.n else ''})"


#: Glyphs of a text sparkline, lowest to highest.
SPARK = "▁▂▃▄▅▆▇█"


def sparkline(values: ArrayLike, width: int = 30) -> str:
    """The last ``width`` values as one line of block glyphs (lowest ▁ … highest █; all equal: ▄)."""
    tail = np.asarray(values, dtype=float)[-width:]
    tail = tail[np.isfinite(tail)]
    if tail.size == 0:
        return ""
    low, high = float(tail.min()), float(tail.max())
    if high <= low:
        return SPARK[3] * int(tail.size)
    levels = np.minimum(((tail - low) / (high - low) * len(SPARK)).astype(int), len(SPARK) - 1)
    return "".join(SPARK[i] for i in levels)


@dataclass(frozen=True)
class CapabilityRow:
    """One line of the TUI's capability table: the characteristic's indices, sparkline and rule flags."""

    name: str
    n: int
    cpk: str
    interval: str
    ppk: str
    out: int
    spark: str
    rules: str
    last_split: str


def capability_rows(outcome: SpcOutcome, width: int = 30) -> list[CapabilityRow]:
    """Rows of the capability table (TUI), one per characteristic, texts ready to show."""
    rows = []
    for d in outcome.dimensions:
        c = d.capability
        rules = " ".join(f"R{r}" for r in sorted({v.rule for v in d.violations})) or "—"
        split = d.splits[-1] if d.splits else None
        change = f"{_f(split.before.cpk)} → {_f(split.after.cpk)}" if split else "—"
        rows.append(
            CapabilityRow(
                d.name,
                c.n,
                _f(c.cpk),
                interval_text(c),
                _f(c.ppk),
                c.out_of_tolerance,
                sparkline(d.values, width),
                rules,
                change,
            )
        )
    return rows
