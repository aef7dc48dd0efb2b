"""Fixture cycles: the parts of a report grouped into loads of a multi-part fixture.

A CMM report often holds one "part" per physical workpiece, while a setup correction
concerns one fixture load (cycle) holding several workpieces at its stations (the
model's dimension ``group``).  :func:`assign_stations` maps parts to stations:

* ``stations`` as a list in part order, or as a mapping part → station (a subset of
  the fixture is allowed: the coverage check says what the others get);
* ``parts_per_cycle=N``: consecutive parts grouped N at a time (a long report of many
  loads), the k-th part of each load at the k-th station of ``stations`` (or of the
  model's groups when there are exactly N, or of the report's own ``station`` column);
* part names equal to the model's groups: one cycle.

A merged cycle is named by its parts (``A7+A8+A9+A10``).  :func:`load_parts` reads a
report, groups it, matches it to the model and checks it against the model
(:mod:`setupfix.inputs.checks`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import pandas as pd

import parsers
from parsers import Source
from setupfix.core.errors import MatchError, Note, SourceLocation
from setupfix.inputs.checks import check_parts
from setupfix.model import PartMeasurement, ProcessModel, match_parts, normalise_name

__all__ = ["ReadOptions", "Stations", "assign_stations", "cycle_name", "load_parts", "model_groups", "read_parts"]

#: Stations of a report's parts: a list in part order or a mapping part → station.
Stations = Sequence[str] | Mapping[str, str]


@dataclass(frozen=True)
class ReadOptions:
    """The report reader's options (``--format``, ``--unit``, ``--encoding``, ``--columns``, ``--lenient``).

    The same for every command: ``kwargs()`` are keyword arguments of :func:`read_parts`
    and of :func:`parsers.read_report`.
    """

    format: str | None = None
    unit: str | None = None
    encoding: str | None = None
    columns: str | None = None
    lenient: bool = False

    def kwargs(self) -> dict[str, Any]:
        """As keyword arguments of :func:`read_parts` (and :func:`parsers.read_report`)."""
        return {
            "format": self.format,
            "unit": self.unit,
            "encoding": self.encoding,
            "columns": self.columns,
            "lenient": self.lenient,
        }


def model_groups(model: ProcessModel) -> list[str]:
    """The model's stations (dimension groups) in the order the file declares them."""
    return list(dict.fromkeys(d.group for d in model.dimensions if d.group))


def cycle_name(parts: Sequence[str]) -> str:
    """The name of a cycle merged from parts: ``"A7+A8"`` (one part keeps its name)."""
    names = [p or "(report)" for p in parts]
    return "+".join(names)


def _check_station(groups: Mapping[str, str], station: str, part: str, report: str) -> str:
    if normalise_name(station) not in groups:
        raise MatchError(
            f"station {station!r} (for part {part!r}) is not a group of the model "
            f"(groups: {', '.join(sorted(set(groups.values())))})",
            location=SourceLocation(report),
        )
    return groups[normalise_name(station)]


def assign_stations(
    model: ProcessModel, table: pd.DataFrame, stations: Stations | None = None, *, parts_per_cycle: int | None = None
) -> pd.DataFrame:
    """Map the parts of a multi-part report to fixture stations and cycles.

    Returns
    -------
    DataFrame
        The table with ``station`` set from the mapping and ``part`` set to the
        cycle name; unchanged when nothing asks for stations.

    Raises
    ------
    MatchError
        If a station is not a group of the model, or the number of stations does not
        fit the number of parts (or ``parts_per_cycle``).
    """
    groups = {normalise_name(g): g for g in model_groups(model)}
    parts = table["part"].fillna("").astype(str) if "part" in table else pd.Series([""] * len(table), index=table.index)
    order = list(dict.fromkeys(parts))
    report = str(table["report"].iloc[0]) if "report" in table and len(table) else "<report>"
    if parts_per_cycle is not None:
        return _by_count(model, table, parts, order, stations, parts_per_cycle, groups, report)
    if stations is None:
        if len(order) > 1 and all(normalise_name(p) in groups for p in order):
            mapping = {p: groups[normalise_name(p)] for p in order}
        else:
            return table
    elif isinstance(stations, Mapping):
        mapping = dict(stations)
        unknown = [p for p in mapping if p not in order]
        if unknown:
            raise MatchError(
                f"--stations names part(s) {', '.join(map(repr, unknown))} the report does not hold "
                f"(parts: {', '.join(order)})",
                location=SourceLocation(report),
            )
    else:
        if len(stations) != len(order):
            raise MatchError(
                f"{len(stations)} stations given for {len(order)} parts in the report ({', '.join(order)})",
                location=SourceLocation(report),
                hint="--parts-per-cycle N groups a long report into loads of N parts",
            )
        mapping = dict(zip(order, stations, strict=True))
    mapping = {part: _check_station(groups, station, part, report) for part, station in mapping.items()}
    out = table.copy()
    out["station"] = parts.map(lambda p: mapping.get(p, ""))
    out["part"] = cycle_name([p for p in order if p in mapping])
    return out


def _by_count(
    model: ProcessModel,
    table: pd.DataFrame,
    parts: pd.Series,
    order: list[str],
    stations: Stations | None,
    n: int,
    groups: Mapping[str, str],
    report: str,
) -> pd.DataFrame:
    if n < 1:
        raise MatchError(f"--parts-per-cycle must be at least 1, got {n}", location=SourceLocation(report))
    if isinstance(stations, Mapping):
        raise MatchError(
            "--parts-per-cycle takes --stations as a list (P1,P2,…), one per position in a load",
            location=SourceLocation(report),
        )
    own = "station" in table and table["station"].notna().all() and (table["station"].astype(str) != "").all()
    if stations is not None:
        if len(stations) != n:
            raise MatchError(f"{len(stations)} stations given for cycles of {n} parts", location=SourceLocation(report))
        slots: list[str] | None = [
            _check_station(groups, s, f"position {k + 1}", report) for k, s in enumerate(stations)
        ]
    elif own or n == 1:
        slots = None  # the report's own station column, or one part per load
    elif len(groups) == n:
        slots = list(groups.values())
    else:
        raise MatchError(
            f"cannot tell the stations of {n} parts per cycle: the model has "
            f"{len(groups)} groups ({', '.join(groups.values()) or 'none'})",
            location=SourceLocation(report),
            hint="give --stations P1,P2,… in load order",
        )
    cycle_of: dict[str, str] = {}
    station_of: dict[str, str] = {}
    for start in range(0, len(order), n):
        chunk = order[start : start + n]
        name = cycle_name(chunk)
        for k, p in enumerate(chunk):
            cycle_of[p] = name
            if slots is not None:
                station_of[p] = slots[k]
    out = table.copy()
    if slots is not None:
        out["station"] = parts.map(station_of)
    out["part"] = parts.map(cycle_of)
    return out


def load_parts(
    model: ProcessModel,
    report: str | Path | Source,
    *,
    format: str | None = None,
    unit: str | None = None,
    encoding: str | None = None,
    columns: str | None = None,
    stations: Stations | None = None,
    parts_per_cycle: int | None = None,
    strict: bool = False,
    lenient: bool = False,
) -> list[PartMeasurement]:
    """Read a report in any supported format, group it into cycles, tie it to the model and check it.

    Raises
    ------
    MatchError
        See :func:`assign_stations`, :func:`setupfix.model.match_parts` and
        :func:`setupfix.inputs.checks.check_parts` (unit error; any difference with ``strict``).
    """
    return read_parts(
        model,
        report,
        format=format,
        unit=unit,
        encoding=encoding,
        columns=columns,
        stations=stations,
        parts_per_cycle=parts_per_cycle,
        strict=strict,
        lenient=lenient,
    )[1]


def read_parts(
    model: ProcessModel,
    report: str | Path | Source,
    *,
    format: str | None = None,
    unit: str | None = None,
    encoding: str | None = None,
    columns: str | None = None,
    stations: Stations | None = None,
    parts_per_cycle: int | None = None,
    strict: bool = False,
    lenient: bool = False,
) -> tuple[parsers.ReadResult, list[PartMeasurement]]:
    """:func:`load_parts` that also returns what was read (table, format), e.g. for the history store."""
    options: dict[str, Any] = {"unit": unit, "encoding": encoding, "lenient": lenient}
    if columns:
        options["columns"] = columns
    read = parsers.read_report(report, format=format, **options)
    table = read.table
    grouped = assign_stations(model, table, stations, parts_per_cycle=parts_per_cycle)
    parts = match_parts(model, grouped, source=str(report))
    if parts_per_cycle is not None and parts_per_cycle > 1:
        order = list(dict.fromkeys(table["part"].fillna("").astype(str))) if "part" in table else [""]
        if len(order) % parts_per_cycle:
            last = parts[-1]
            parts[-1] = _with_note(
                last,
                Note(
                    f"the last cycle {last.part} holds {len(order) % parts_per_cycle} of {parts_per_cycle} parts",
                    SourceLocation(str(report)),
                    "cycle",
                ),
            )
    checked = check_parts(model, parts, strict=strict, source=str(report))
    # the reader's notes (skipped rows, assumed units) travel with every cycle they concern, as data
    return read, ([replace(p, notes=(*read.notes, *p.notes)) for p in checked] if read.notes else checked)


def _with_note(part: PartMeasurement, note: Note) -> PartMeasurement:
    return replace(part, notes=(*part.notes, note))
