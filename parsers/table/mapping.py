"""Column mapping of shop tables: which of the shop's headers holds which canonical value.

A mapping is given as ``actual=Meas,nominal=Nom,...`` on the command line, as a
small file (TOML with a ``[columns]`` table, or ``key = header`` lines), or guessed
from common header spellings (English and German) when none is given.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Iterable, Mapping
from pathlib import Path

from setupfix.core.errors import ParseError, SourceLocation

__all__ = ["KEYS", "OPTION_KEYS", "parse_columns", "guess_columns"]

#: Values a shop column may be mapped to: the canonical columns, plus absolute limits
#: (``lsl``/``usl``) and a symmetric ± ``tolerance``.
KEYS = (
    "characteristic",
    "nominal",
    "actual",
    "deviation",
    "lower",
    "upper",
    "lsl",
    "usl",
    "tolerance",
    "unit",
    "part",
    "report",
    "timestamp",
    "station",
    "x",
    "y",
    "z",
    "status",
    "x_actual",
    "y_actual",
    "z_actual",
    "uncertainty",
)
#: Options a mapping may carry besides columns.
OPTION_KEYS = ("sheet",)

#: Header spellings recognised without a mapping, lower case, spaces and punctuation removed.
_SYNONYMS: dict[str, tuple[str, ...]] = {
    "characteristic": (
        "characteristic",
        "name",
        "feature",
        "char",
        "merkmal",
        "label",
        "dimension",
        "description",
        "bezeichnung",
        "characteristicname",
    ),
    "nominal": ("nominal", "nom", "soll", "sollwert", "target", "nominalvalue"),
    "actual": ("actual", "meas", "measured", "measurement", "ist", "istwert", "measuredvalue", "actualvalue"),
    "deviation": ("deviation", "dev", "abw", "abweichung", "error"),
    "lower": ("lower", "lowertol", "lowertolerance", "tolminus", "untereabw", "ut"),
    "upper": ("upper", "uppertol", "uppertolerance", "tol+", "tolplus", "obereabw", "ot"),
    "lsl": ("lsl", "lowerlimit", "min", "ugw"),
    "usl": ("usl", "upperlimit", "max", "ogw"),
    "unit": ("unit", "einheit", "units"),
    "part": ("part", "serial", "serialnumber", "partno", "partnb", "teil"),
    "station": ("station", "nest", "fixture"),
    "timestamp": ("timestamp", "date", "datetime", "time", "datum"),
    "x": ("x",),
    "y": ("y",),
    "z": ("z",),
    "status": ("status", "result", "verdict"),
    "x_actual": ("xactual", "xist", "xmeas", "xmeasured"),
    "y_actual": ("yactual", "yist", "ymeas", "ymeasured"),
    "z_actual": ("zactual", "zist", "zmeas", "zmeasured"),
    "uncertainty": ("uncertainty", "measurementuncertainty", "expandeduncertainty", "messunsicherheit"),
}


def _squash(text: str) -> str:
    return re.sub(r"[\s_.\-()\[\]]+", "", text.strip().lower())


def _check(mapping: dict[str, str], where: SourceLocation) -> dict[str, str]:
    unknown = [k for k in mapping if k not in KEYS and k not in OPTION_KEYS]
    if unknown:
        raise ParseError(f"unknown column key(s) {', '.join(unknown)} (known: {', '.join(KEYS)})", location=where)
    return mapping


def parse_columns(spec: str | Path | Mapping[str, str] | None) -> dict[str, str]:
    """Turn a ``--columns`` value into ``{canonical key: shop header}``.

    Parameters
    ----------
    spec : str, Path, mapping or None
        ``"actual=Meas,nominal=Nom"``, the path of a mapping file, a ready mapping,
        or None (empty mapping).

    Raises
    ------
    ParseError
        On a malformed pair, an unknown key or an unreadable mapping file.
    """
    if spec is None:
        return {}
    if isinstance(spec, Mapping):
        return _check({str(k).strip().lower(): str(v).strip() for k, v in spec.items()}, SourceLocation("--columns"))
    text = str(spec)
    candidate = Path(text)
    if "=" not in text or candidate.suffix.lower() in (".toml", ".txt", ".map", ".ini"):
        return _read_mapping_file(candidate)
    mapping: dict[str, str] = {}
    for pair in text.split(","):
        key, sep, value = pair.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise ParseError(f"expected KEY=HEADER, found {pair.strip()!r}", location=SourceLocation("--columns"))
        mapping[key.strip().lower()] = value.strip()
    return _check(mapping, SourceLocation("--columns"))


def _read_mapping_file(path: Path) -> dict[str, str]:
    where = SourceLocation(str(path))
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise ParseError(f"cannot read column mapping: {exc}", location=where) from None
    if path.suffix.lower() == ".toml":
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ParseError(f"bad TOML: {exc}", location=where) from None
        table = data.get("columns", data)
        if not isinstance(table, dict) or not all(isinstance(v, str) for v in table.values()):
            raise ParseError('expected a [columns] table of KEY = "header"', location=where)
        return _check({k.lower(): v for k, v in table.items()}, where)
    mapping: dict[str, str] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        key, sep, value = line.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise ParseError(f"expected KEY = HEADER, found {line!r}", location=SourceLocation(str(path), line=number))
        mapping[key.strip().lower()] = value.strip().strip('"')
    return _check(mapping, where)


def guess_columns(headers: Iterable[str], given: Mapping[str, str]) -> dict[str, str]:
    """Complete ``given`` with the headers whose spelling says what they hold.

    A header already used by ``given`` is not reused; ambiguous spellings (two
    headers for one key) leave the key to the user.
    """
    result = {k: v for k, v in given.items() if k in KEYS}
    used = {v.strip().lower() for v in result.values()}
    found: dict[str, list[str]] = {}
    for header in headers:
        if header.strip().lower() in used:
            continue
        squashed = _squash(header)
        for key, names in _SYNONYMS.items():
            if key not in result and squashed in names:
                found.setdefault(key, []).append(header)
    for key, headers_for_key in found.items():
        if len(headers_for_key) == 1:
            result[key] = headers_for_key[0]
    return result
