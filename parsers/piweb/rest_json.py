"""ZEISS PiWeb REST JSON: a values file (``DataMeasurementDto`` list) with its characteristics file.

``PiWebApi_sample_values.json`` is a list of measurements, each with measurement
attributes (K-numbers without the ``K``: 4 time, 7 nest, 14 part ident) and
``characteristics`` mapping a characteristic UUID to value attributes (1 = measured
value).  Nominal and limits live in the characteristics file
(``PiWebApi_sample_characteristics.json``: 2101 nominal, 2110/2111 absolute lower/upper
limits, 2112/2113 relative allowances, 2142 unit), found beside the values file by
replacing ``values`` with ``characteristics`` in its name.

Each measurement is one part.  The characteristic name is the last segment of its
PiWeb path (``PC:/Blechteil/Abweichung_3/`` → ``Abweichung_3``).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pandas as pd

from parsers.numbers import MAX_NUMBER_CHARS, parse_number
from parsers.rows import SkipLog, finish_rows, unit_factor, unit_or_none, warn_assumed_mm
from parsers.source import Source, load_source, read_text
from setupfix.core.errors import ParseError, SourceLocation

__all__ = ["read_piweb", "sniff_piweb"]

_MICRO = {"µm", "um", "μm"}


def sniff_piweb(text: str) -> bool:
    """True for a PiWeb REST JSON list (values, characteristics, measurements). Never raises."""
    try:
        head = text.lstrip("\ufeff \r\n\t")
        if not head.startswith("["):
            return False
        return bool(
            re.search(r'"(characteristics|partUuid)"\s*:', head[:4096])
            or re.search(r'"path"\s*:\s*"(PC|P):/', head[:4096])
        )
    except Exception:  # noqa: BLE001 - a sniffer never raises
        return False


def _load(path: Path | Source, encoding: str | None) -> object:
    text = read_text(path, encoding).lstrip("\ufeff")
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ParseError(f"not JSON: {exc.msg}", location=SourceLocation(str(path), line=exc.lineno)) from None
    except RecursionError:
        raise ParseError("JSON nested too deeply", location=SourceLocation(str(path))) from None


def _number(value: object, where: SourceLocation, what: str) -> float | None:
    if value is None or value == "":
        return None
    if isinstance(value, bool):
        raise ParseError(f"{what}: expected a number, found {value!r}", location=where)
    if isinstance(value, str):
        return parse_number(value, decimal="auto", location=where, what=what)
    if isinstance(value, int) and abs(value) > 10**MAX_NUMBER_CHARS:
        raise ParseError(f"{what}: {len(str(value))}-digit integer is not a measurement", location=where)
    if not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ParseError(f"{what}: expected a finite number, found {str(value)[:30]!r}", location=where)
    return float(value)


def _characteristics(data: object, name: str) -> dict[str, dict[str, object]]:
    if not isinstance(data, list):
        raise ParseError("characteristics file is not a JSON list", location=SourceLocation(name))
    table: dict[str, dict[str, object]] = {}
    for i, item in enumerate(data):
        if not isinstance(item, dict) or not isinstance(item.get("uuid"), str):
            raise ParseError("characteristic without uuid", location=SourceLocation(name, key=f"[{i}]"))
        attributes = item.get("attributes") or {}
        if not isinstance(attributes, dict):
            raise ParseError("attributes is not an object", location=SourceLocation(name, key=f"[{i}].attributes"))
        path = str(item.get("path") or "")
        label = [seg for seg in path.split(":", 1)[-1].split("/") if seg]
        table[item["uuid"]] = {"name": label[-1] if label else item["uuid"], "attributes": attributes, "index": i}
    return table


def _limits(attributes: dict[str, object], nominal: float, factor: float, where: SourceLocation) -> tuple[float, float]:
    lo_abs, up_abs = _number(attributes.get("2110"), where, "2110"), _number(attributes.get("2111"), where, "2111")
    lo_rel, up_rel = _number(attributes.get("2112"), where, "2112"), _number(attributes.get("2113"), where, "2113")
    lower = lo_abs * factor - nominal if lo_abs is not None else (lo_rel * factor if lo_rel is not None else math.nan)
    upper = up_abs * factor - nominal if up_abs is not None else (up_rel * factor if up_rel is not None else math.nan)
    if not math.isnan(lower) and not math.isnan(upper) and lower >= upper:
        raise ParseError(f"lower limit {lower:g} is not below upper limit {upper:g}", location=where)
    return lower, upper


def _position(attributes: dict[str, object], factor: float, where: SourceLocation) -> dict[str, float]:
    """Nominal location (2543/2544/2545) as x, y, z in mm, NaN where absent."""
    out = {}
    for axis, key in (("x", "2543"), ("y", "2544"), ("z", "2545")):
        value = _number(attributes.get(key), where, key)
        out[axis] = math.nan if value is None else value * factor
    return out


def read_piweb(path: str | Path, *, unit: str | None = None, encoding: str | None = None) -> pd.DataFrame:
    """Read a PiWeb values JSON (with its characteristics JSON beside it) into the canonical table.

    Parameters
    ----------
    path : str or Path
        The values file.
    unit : {"mm", "inch"}, optional
        Unit of characteristics without attribute 2142 (default mm, with a warning).
    encoding : str, optional

    Raises
    ------
    ParseError
        If the file is a characteristics, measurements or parts file (no values), the
        characteristics file is missing, or a value is not a number.
    """
    source = load_source(path)
    name = str(source)
    default = unit_or_none(unit) if unit else None
    if unit and default is None:
        raise ParseError(f"unknown unit {unit!r} (expected mm or inch)", location=SourceLocation(name))
    data = _load(source, encoding)
    if not isinstance(data, list) or not data or not isinstance(data[0], dict):
        raise ParseError("not a PiWeb list of measurements", location=SourceLocation(name))
    if "characteristics" not in data[0] or not isinstance(data[0]["characteristics"], dict):
        first = data[0]
        kind = (
            "parts"
            if "charChangeDate" in first
            else "measurements (attributes, no values)"
            if "partUuid" in first
            else "characteristics (nominals, no values)"
            if "path" in first
            else "JSON"
        )
        raise ParseError(
            f"PiWeb {kind} file holds no measured values",
            location=SourceLocation(name),
            hint="read the values file; its characteristics file beside it is used for nominals",
        )
    chars_path = source.path.with_name(source.path.name.replace("values", "characteristics"))
    if chars_path == source.path or not chars_path.exists():
        raise ParseError(
            f"characteristics file {chars_path.name} not found beside the values file", location=SourceLocation(name)
        )
    chars = _characteristics(_load(chars_path, encoding), str(chars_path))
    skipped = SkipLog(name)
    rows: list[dict[str, object]] = []
    unstated = False
    for i, measurement in enumerate(data):
        mwhere = SourceLocation(name, key=f"[{i}]")
        if not isinstance(measurement, dict) or not isinstance(measurement.get("characteristics"), dict):
            raise ParseError("measurement without characteristics", location=mwhere)
        attributes = measurement.get("attributes") or {}
        if not isinstance(attributes, dict):
            raise ParseError("attributes is not an object", location=mwhere)
        part = str(attributes.get("14") or measurement.get("uuid") or f"measurement {i + 1}")
        stamp = str(attributes.get("4") or "")
        nest = attributes.get("7")
        for uuid, value in measurement["characteristics"].items():
            where = SourceLocation(name, key=f"[{i}].characteristics.{uuid}")
            char = chars.get(uuid)
            if char is None:
                raise ParseError("value of a characteristic the characteristics file does not hold", location=where)
            cattr = char["attributes"]
            assert isinstance(cattr, dict)
            actual = _number(value.get("1") if isinstance(value, dict) else None, where, "value 1")
            if actual is None:
                skipped.add("empty value(s)", f"[{i}]")
                continue
            unit_text = str(cattr.get("2142") or "").strip()
            if unit_text in _MICRO:
                factor = 0.001
            elif unit_text:
                known = unit_or_none(unit_text)
                if known is None:
                    skipped.add(f"value(s) in a non-length unit ({unit_text})", f"[{i}]")
                    continue
                factor = unit_factor(known)
            else:
                unstated |= default is None
                factor = unit_factor(default or "mm")
            nominal = _number(cattr.get("2101"), where, "2101 nominal")
            if nominal is None:
                skipped.add("value(s) of characteristics without nominal (2101)", f"[{i}]")
                continue
            nominal *= factor
            lower, upper = _limits(cattr, nominal, factor, where)
            rows.append(
                {
                    "characteristic": char["name"],
                    "nominal": nominal,
                    "actual": actual * factor,
                    "deviation": actual * factor - nominal,
                    "lower": lower,
                    "upper": upper,
                    "part": part,
                    "timestamp": stamp,
                    "station": "" if nest in (None, "") else str(nest),
                    "status": "",
                    **_position(cattr, factor, where),
                    "source": f"{name}#[{i}]/{char['name']}",
                }
            )
    if rows and unstated:
        warn_assumed_mm(name, "[0]")
    return finish_rows(rows, name, skipped, what="PiWeb")
