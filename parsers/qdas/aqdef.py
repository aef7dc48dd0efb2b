"""Q-DAS AQDEF transfer files: ``.dfq`` (description and values), ``.dfd`` + ``.dfx`` pairs.

Each line is a K-field ``Kkkkk[/i] value`` or an uncoded value line.  ``/i`` is the
part index for K1xxx, the characteristic index for K2xxx and K0xxx; ``/0`` applies a
field to every part or characteristic (an explicit index wins); a value field (K0002,
K0004 …) written without ``/i`` belongs to the value line just above it (the last
K0001 line, or every value of the last uncoded line), and a date (K0004) with no
value of its (variable) characteristic above it is refused, not dropped.  Values come either
as K-field lines (``K0001/2 3.1`` followed by ``K0004/2 …``) or as one uncoded line
per measured piece: characteristics separated by 0x0F, their fields by 0x14 in the
order K0001 K0002 K0004 K0005 K0006 K0007 K0008 K0010 K0011 K0012.

Each measured piece (one value of every characteristic) is one row group; its
``part`` is the part ident K0014 when the file gives one, else ``<K1001>#<n>``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import pandas as pd

from parsers.rows import (
    SkipLog,
    finish_rows,
    parse_number,
    try_number,
    unit_factor,
    unit_or_none,
    warn_assumed_mm,
)
from parsers.source import load_source, read_text
from setupfix.core.errors import ParseError, SourceLocation

__all__ = ["read_aqdef", "sniff_aqdef"]

_KLINE = re.compile(r"^K(\d{4})(?:/(\d{1,9}))?(?:[ \t](.*))?$")
_SI, _DC4 = "\x0f", "\x14"
#: Field order inside one characteristic of an uncoded value line (variable characteristic).
_VALUE_FIELDS = ("K0001", "K0002", "K0004", "K0005", "K0006", "K0007", "K0008", "K0010", "K0011", "K0012")
#: K0002 attribute values meaning "no valid value" (255 invalid, 256 deleted).
_INVALID_ATTRIBUTES = {"255", "256"}
_DATE = re.compile(r"^(\d{1,2})\.(\d{1,2})\.(\d{4})(?:[/ T](\d{1,2}):(\d{2})(?::(\d{2}))?)?$")
#: Dates already converted (a value file repeats the same few thousand stamps).
_DATES: dict[str, str] = {}
#: Units that are lengths but not in setupfix.core.units: micrometres.
_MICRO = {"µm", "um", "μm"}


def sniff_aqdef(text: str, suffix: str = "") -> bool:
    """True if ``text`` starts with a K-field line, or is an uncoded ``.dfx``/``.dfb`` value file. Never raises."""
    try:
        head = text.lstrip("\ufeff \r\n")
        if re.match(r"K\d{4}(?:/\d+)? ", head):
            return True
        return suffix in (".dfx", ".dfb") and (_SI in head[:4096] or _DC4 in head[:4096])
    except Exception:  # noqa: BLE001 - a sniffer never raises
        return False


@dataclass
class _Char:
    """One characteristic: its K2xxx fields and the line each came from."""

    fields: dict[str, str] = field(default_factory=dict)
    lines: dict[str, SourceLocation] = field(default_factory=dict)
    part: int = 1


@dataclass
class _Value:
    """One measured value of one characteristic, with its sample-level fields."""

    char: int
    sample: int
    where: SourceLocation
    fields: dict[str, str] = field(default_factory=dict)


@dataclass
class _State:
    parts: dict[int, dict[str, str]] = field(default_factory=dict)
    chars: dict[int, _Char] = field(default_factory=dict)
    all_chars: dict[str, str] = field(default_factory=dict)
    all_parts: dict[str, str] = field(default_factory=dict)
    values: list[_Value] = field(default_factory=list)
    last_value: dict[int, _Value] = field(default_factory=dict)
    #: The values of the last K0001 line or uncoded value line (what an unindexed K0xxx field follows).
    last_read: list[_Value] = field(default_factory=list)
    samples: dict[int, int] = field(default_factory=dict)
    coded_lines: int = 0
    current_part: int = 1


def _lines(text: str, name: str) -> list[tuple[SourceLocation, str]]:
    return [(SourceLocation(name, line=n), line.rstrip("\r")) for n, line in enumerate(text.split("\n"), 1)]


def _feed_kline(state: _State, key: str, index: int | None, value: str, where: SourceLocation) -> None:
    group = key[1]
    if group == "1":
        if index == 0:
            state.all_parts[key] = value
            return
        part = 1 if index is None else index
        state.parts.setdefault(part, {})[key] = value
        state.current_part = part
    elif group in "2345678" and key < "K9000":
        if index == 0:
            state.all_chars[key] = value
            return
        if index is None:
            raise ParseError(f"{key} needs a characteristic index (/i)", location=where)
        if index not in state.chars:
            state.chars[index] = _Char(part=state.current_part)
        state.chars[index].fields.setdefault(key, value)
        state.chars[index].lines.setdefault(key, where)
    elif group == "0":
        if key == "K0100":
            return
        if key == "K0001":
            if index is None or index == 0:
                raise ParseError("K0001 needs a characteristic index (/i)", location=where)
            state.samples[index] = state.samples.get(index, 0) + 1
            item = _Value(index, state.samples[index], where, {"K0001": value})
            state.values.append(item)
            state.last_value[index] = item
            state.last_read = [item]
            return
        if index == 0:
            targets = list(state.last_value.values())
        elif index is None:  # written without /i: the field of the value line(s) just above
            targets = state.last_read
        else:
            found = state.last_value.get(index)
            targets = [] if found is None else [found]
        if not targets and key == "K0004" and index and _variable(state, index):
            raise ParseError(
                f"{key} (date) before a value of characteristic {index}: a K0004 line follows the K0001 line it dates",
                location=where,
            )
        for target in targets:
            target.fields[key] = value


def _variable(state: _State, index: int) -> bool:
    """Whether characteristic ``index`` is described as variable (K2004 0 or absent; attributive ones have no K0001)."""
    char = state.chars.get(index)
    kind = (char.fields.get("K2004") if char else None) or state.all_chars.get("K2004", "0")
    return kind.strip() in ("", "0")


def _feed_value_line(state: _State, line: str, where: SourceLocation) -> None:
    state.coded_lines += 1
    groups = line.split(_SI)
    state.last_read = []
    for number, group in enumerate(groups, 1):
        parts = group.split(_DC4)
        if len(parts) > 20:
            raise ParseError(f"characteristic {number}: {len(parts)} fields in a value group", location=where)
        fields = dict(zip(_VALUE_FIELDS, parts, strict=False))  # a short group, or fields past K0012 (unused)
        item = _Value(number, state.coded_lines, where, fields)
        state.samples[number] = state.coded_lines
        state.values.append(item)
        state.last_value[number] = item
        state.last_read.append(item)


def _parse(state: _State, lines: list[tuple[SourceLocation, str]]) -> None:
    for where, line in lines:
        if not line.strip():
            continue
        if _SI in line or _DC4 in line:
            _feed_value_line(state, line, where)
            continue
        match = _KLINE.match(line.lstrip("\ufeff"))
        if not match:
            if try_number(line) is not None:
                # A value file of a single characteristic has neither separator.
                _feed_value_line(state, line, where)
                continue
            raise ParseError(f"not a K-field or value line: {line[:40]!r}", location=where)
        key, index, value = f"K{match.group(1)}", match.group(2), (match.group(3) or "").strip()
        _feed_kline(state, key, None if index is None else int(index), value, where)


def _date(text: str, where: SourceLocation) -> str:
    text = text.strip()
    if text in _DATES:
        return _DATES[text]
    if not text:
        return ""
    match = _DATE.match(text)
    if not match:
        raise ParseError(f"K0004: date {text!r} is not dd.mm.yyyy/hh:mm:ss", location=where)
    d, m, y, hh, mm, ss = match.groups()
    if not (1 <= int(m) <= 12 and 1 <= int(d) <= 31):
        raise ParseError(f"K0004: date {text!r} out of range", location=where)
    stamp = f"{y}-{int(m):02d}-{int(d):02d}" + (f"T{int(hh):02d}:{mm}:{ss or '00'}" if hh is not None else "")
    if len(_DATES) < 100_000:
        _DATES[text] = stamp
    return stamp


def _char_unit(char: _Char, default: str | None) -> tuple[str | None, float]:
    """(unit label, mm factor); (None, nan) for a non-length unit; unit label '' when unstated."""
    text = char.fields.get("K2142", "").strip()
    if not text:
        return "", unit_factor(default) if default else 1.0
    if text in _MICRO:
        return "um", 0.001
    unit = unit_or_none(text)
    return (unit, unit_factor(unit)) if unit else (None, math.nan)


def _limits(char: _Char, nominal: float, factor: float, where: SourceLocation) -> tuple[float, float]:
    def num(key: str) -> float | None:
        text = char.fields.get(key, "").strip()
        return None if text == "" else parse_number(text, char.lines.get(key, where), key) * factor

    lo_abs, up_abs, lo_rel, up_rel = num("K2110"), num("K2111"), num("K2112"), num("K2113")
    lower = lo_abs - nominal if lo_abs is not None else lo_rel
    upper = up_abs - nominal if up_abs is not None else up_rel
    for absolute, relative, key in ((lo_abs, lo_rel, "K2112"), (up_abs, up_rel, "K2113")):
        if (
            absolute is not None
            and relative is not None
            and abs(absolute - nominal - relative) > 1e-6 * max(1.0, abs(nominal))
        ):
            raise ParseError(f"{key} allowance contradicts the absolute limit", location=char.lines.get(key, where))
    lo = math.nan if lower is None else lower
    up = math.nan if upper is None else upper
    if not math.isnan(lo) and not math.isnan(up) and lo >= up:
        raise ParseError(f"lower limit {lo:g} is not below upper limit {up:g}", location=char.lines.get("K2110", where))
    return lo, up


def _beside(path: Path, suffix: str) -> Path:
    """The file of the same stem beside ``path`` with ``suffix`` in any letter case (or the lower-case name)."""
    exact = path.with_suffix(suffix)
    if exact.exists():
        return exact
    pattern = path.stem + "." + "".join(f"[{c.lower()}{c.upper()}]" for c in suffix[1:])
    return next(iter(sorted(path.parent.glob(pattern))), exact)


def read_aqdef(path: str | Path, *, unit: str | None = None, encoding: str | None = None) -> pd.DataFrame:
    """Read a Q-DAS AQDEF ``.dfq``, or a ``.dfd`` with its ``.dfx`` (or ``.dfb``) values, into the canonical table.

    Parameters
    ----------
    path : str or Path
        A ``.dfq``; or either file of a ``.dfd``/``.dfx`` pair (the other is found
        beside it under the same stem).
    unit : {"mm", "inch"}, optional
        Unit of characteristics without K2142 (default mm, with a warning).
    encoding : str, optional
        Text encoding (sniffed when omitted; Q-DAS files are often Windows-1252).

    Raises
    ------
    ParseError
        On a malformed line, a value of an unknown characteristic, a contradictory
        limit, or when no variable length characteristic with nominal and value is left.
    """
    source = load_source(path)
    path = source.path
    name = str(source)
    suffix = path.suffix.lower()
    lines: list[tuple[SourceLocation, str]] = []
    if suffix in (".dfd", ".dfx", ".dfb"):
        dfd = _beside(path, ".dfd") if suffix != ".dfd" else path
        values = (
            path
            if suffix != ".dfd"
            else (_beside(path, ".dfx") if _beside(path, ".dfx").exists() else _beside(path, ".dfb"))
        )
        for part in (dfd, values):
            if not part.exists() and part != path:
                raise ParseError(
                    f"{part.name} not found beside it",
                    location=SourceLocation(name),
                    hint="a .dfd description and its .dfx (or .dfb) values are read together",
                )
            lines += _lines(read_text(source if part == path else part, encoding), str(part))
    else:
        lines = _lines(read_text(source, encoding), name)
    state = _State()
    _parse(state, lines)
    default_unit = None
    if unit:
        default_unit = unit_or_none(unit)
        if default_unit is None:
            raise ParseError(f"unknown unit {unit!r} (expected mm or inch)", location=SourceLocation(name))
    return _rows(state, name, default_unit)


class _Prepared(NamedTuple):
    """What every value of one characteristic shares (lengths in mm; unit None: not a length)."""

    unit: str | None
    factor: float
    nominal: float | None
    lower: float | None
    upper: float | None
    part_no: str
    name: str


def _prepare(char: _Char, item: _Value, state: _State, default_unit: str | None) -> _Prepared:
    """Unit, nominal and limits in mm, part number and name of one characteristic."""
    unit_label, factor = _char_unit(char, default_unit)
    nominal = lower = upper = None
    nominal_text = char.fields.get("K2101", "").strip()
    if unit_label is not None and nominal_text:
        nominal = parse_number(nominal_text, char.lines.get("K2101", item.where), "K2101") * factor
        lower, upper = _limits(char, nominal, factor, item.where)
    part_fields = {**state.all_parts, **state.parts.get(char.part, {})}
    part_no = part_fields.get("K1001", "").strip() or f"part {char.part}"
    name = (char.fields.get("K2002") or char.fields.get("K2001") or f"K2001/{item.char}").strip()
    return _Prepared(unit_label, factor, nominal, lower, upper, part_no, name)


def _rows(state: _State, name: str, default_unit: str | None) -> pd.DataFrame:
    skipped = SkipLog(name)
    rows: list[dict[str, object]] = []
    cache: dict[int, _Prepared] = {}
    unstated_unit = False
    for described in state.chars.values():
        for key, value in state.all_chars.items():
            described.fields.setdefault(key, value)
    for item in state.values:
        char = state.chars.get(item.char)
        line: int | str = item.where.line or 0
        if item.where.path != name:
            line = f"{Path(item.where.path).name}:{line}"
        if char is None:
            raise ParseError(
                f"value of characteristic {item.char}, which the file does not describe", location=item.where
            )
        kind = char.fields.get("K2004", "0").strip() or "0"
        if kind != "0":
            skipped.add(f"value(s) of attributive characteristics (K2004={kind})", line)
            continue
        prepared = cache.get(item.char)
        if prepared is None:
            prepared = cache[item.char] = _prepare(char, item, state, default_unit)
        unit_label, factor, nominal, lower, upper, part_no, characteristic = prepared
        if unit_label is None:
            skipped.add(f"value(s) in a non-length unit (K2142={char.fields['K2142'].strip()})", line)
            continue
        raw = item.fields.get("K0001", "").strip()
        if raw == "" or item.fields.get("K0002", "").strip() in _INVALID_ATTRIBUTES:
            skipped.add("empty or invalid value(s) (K0002=255/256)", line)
            continue
        if nominal is None:
            skipped.add("value(s) of characteristics without nominal (K2101)", line)
            continue
        unstated_unit |= unit_label == "" and default_unit is None
        actual = parse_number(raw, item.where, "K0001 value") * factor
        ident = item.fields.get("K0014", "").strip()
        nest = item.fields.get("K0007", "").strip()
        rows.append(
            {
                "characteristic": characteristic,
                "nominal": nominal,
                "actual": actual,
                "deviation": actual - nominal,
                "lower": lower,
                "upper": upper,
                "part": ident or f"{part_no}#{item.sample}",
                "timestamp": _date(item.fields.get("K0004", ""), item.where),
                "station": "" if nest in ("", "0") else nest,
                "status": "",
                "source": f"{item.where.path}:{line}",
            }
        )
    valued = {item.char for item in state.values}
    for number, char in state.chars.items():
        kind = char.fields.get("K2004", "0").strip() or "0"
        if number not in valued and kind != "0":
            where = char.lines.get("K2004") or SourceLocation(name)
            skipped.add(f"attributive characteristic(s) without variable values (K2004={kind})", where.line or 0)
    if rows and unstated_unit:
        warn_assumed_mm(name, str(rows[0]["source"]).rsplit(":", 1)[-1])
    return finish_rows(rows, name, skipped, what="Q-DAS")
