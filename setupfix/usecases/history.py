"""Use cases of the history store: import files, summarise, export the canonical tables and the audit, migrate.

Shared by ``setupfix history`` and, later, batch and the TUI.  An import reads and
checks every file first (reports through :mod:`parsers`, the corrections log and the
temperature log through their readers) and then stores everything in one
transaction: a bad file, a contradiction with the store or a kill leaves the store as
it was.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

import parsers
from parsers.corrections import EVENTS, check_corrections, read_corrections_log
from parsers.names import visible_name
from parsers.source import read_bytes
from parsers.temperature import read_temperature_log
from parsers.timestamps import iso_text
from setupfix.core.errors import Note, ParameterError, ParseError, SourceLocation, StoreError, UnknownFormatError
from setupfix.inputs.stores import DEFAULT_DB, StoreRef, store_location
from setupfix.model import CANONICAL_COLUMNS, ProcessModel
from setupfix.outputs.dfq import export_dfq
from setupfix.outputs.writers import csv_cell, escape_formulas, write_canonical_csv, write_table_csv
from setupfix.store import Recommendation, Store, excluded_reports
from setupfix.store.audit import TABLES
from setupfix.usecases.batch_records import exclusion
from setupfix.usecases.contract import cycle_json
from setupfix.usecases.export import Exported
from setupfix.usecases.requests import CycleCorrection, ReadOptions

__all__ = [
    "DEFAULT_DB",
    "store_location",
    "import_history",
    "ImportRequest",
    "ImportSummary",
    "history_summary",
    "export_history",
    "record_recommendations",
    "record_correction",
    "mark_report",
    "migrate_history",
    "EXPORTS",
    "EVENTS",
]

#: Tables ``history export`` writes (``recommendations``: the audit trail, one row per register component).
EXPORTS = ("measurements", "corrections", "temperatures", "recommendations", "dfq")


def _temperature_frame(path: str | os.PathLike[str]) -> pd.DataFrame:
    """A temperature log (:func:`parsers.temperature.read_temperature_log`) as the store keeps it."""
    log = read_temperature_log(Path(path))
    if not log.timestamps:
        raise ParseError(
            "a temperature log for the history store needs a 'timestamp' column",
            location=log.location(),
            hint="the store ties samples to parts by time",
        )
    stamps = [iso_text(t, log.location(i)) for i, t in enumerate(log.timestamps)]
    return pd.DataFrame({"timestamp": stamps, **log.columns})


@dataclass(frozen=True)
class ImportRequest:
    """What ``history import`` stores: report files or folders, corrections and temperature logs.

    ``read`` holds the report reader's options; with ``model`` every corrections-log row
    is checked against it.
    """

    reports: tuple[str | os.PathLike[str], ...] = ()
    corrections: tuple[str | os.PathLike[str], ...] = ()
    temperatures: tuple[str | os.PathLike[str], ...] = ()
    read: ReadOptions = field(default_factory=ReadOptions)
    model: ProcessModel | None = None


@dataclass(frozen=True)
class ImportSummary:
    """What one import stored: new reports, reports already there, new log rows, and the notes."""

    new_reports: tuple[str, ...] = ()
    known_reports: tuple[str, ...] = ()
    corrections: int = 0
    temperatures: int = 0
    notes: tuple[Note, ...] = ()


def import_history(store: Store, request: ImportRequest) -> ImportSummary:
    """Read every file, then store all of it in one transaction.

    ``request.reports`` may name folders: their reports as :func:`parsers.expand_inputs` lists
    them (sub-folders too; each listing problem becomes a note; a file of a folder that
    no reader recognises is left out with a note), and a corrections or temperature log
    found in them is imported when none is given.  With ``model`` every corrections-log
    row is checked against it (:func:`parsers.corrections.check_corrections`), as
    ``diagnose`` checks it.

    Raises
    ------
    SetupfixError
        The first file that cannot be read (nothing is stored), or a log row that
        contradicts the store or the model (nothing is stored).
    StoreError
        A damaged store (checked whole first), or one that cannot be written.
    """
    read = []
    options = request.read
    inputs = parsers.expand_inputs(request.reports)
    notes: list[Note] = inputs.notes()
    for name, from_folder in inputs.files:
        source = parsers.load_source(name)  # read once: the bytes hashed are the bytes parsed
        try:
            result = parsers.read_report(
                source, format=options.format, unit=options.unit, encoding=options.encoding, lenient=options.lenient
            )
        except UnknownFormatError as exc:
            if not from_folder or options.format:
                raise
            notes.append(Note("not a report of a known format; left out", exc.location, "skipped"))
            continue
        notes += result.notes
        read.append((source.data, source.name, result.format, result.table))
    corrections, temperatures = list(request.corrections), list(request.temperatures)
    for kind, given in (("corrections", corrections), ("temperatures", temperatures)):
        found = inputs.log(kind)
        if found and not given:
            given.append(found)
            notes.append(Note(f"{kind} log {found} found beside the reports: imported", None, "folder_log"))
    logs = [read_corrections_log(p) for p in corrections]
    if request.model is not None:
        for log in logs:
            check_corrections(log, request.model)
    temps = [_temperature_frame(p) for p in temperatures]
    new_reports: list[str] = []
    known_reports: list[str] = []
    n_corrections = n_temperatures = 0
    store.verify()  # a damaged store is refused, not written into
    with store.transaction():
        for data, name, fmt, table in read:
            held = store.report(hashlib.sha256(data).hexdigest())  # an import gives no verdict: a mark stays
            _, new = store.add_report(data, Path(name).name, fmt, table, excluded=held.excluded if held else None)
            (new_reports if new else known_reports).append(name)
        for log in logs:
            n_corrections += store.add_corrections(log.frame())
        for frame in temps:
            n_temperatures += store.add_temperatures(frame)
    return ImportSummary(tuple(new_reports), tuple(known_reports), n_corrections, n_temperatures, tuple(notes))


def history_summary(store: Store, *, every_machine: bool = True) -> dict[str, object]:
    """What the store holds for each machine, and, unless ``every_machine``, the detail of the handle's machine:
    its reports (name, reader, rows, parts, first and last timestamp), corrections, tool changes, temperatures.

    The per-machine summary is one aggregate query per table (:meth:`~setupfix.store.Store.machines`); the
    detail reads that machine's rows.  The store is checked whole first (:meth:`~setupfix.store.Store.verify`):
    a damaged one is refused, not summarised from what happens to be readable.
    """
    store.verify()
    summary: dict[str, object] = {
        "store": store.location,
        "machines": [dataclasses.asdict(m) for m in store.machines()],
    }
    if every_machine:
        return summary
    rows = store.measurements(include_excluded=True)
    reports = []
    for rec in store.reports():
        mine = rows[rows["report_sha256"] == rec.sha256]
        stamps = mine["timestamp"].dropna()
        reports.append(
            {
                "report": rec.name,
                "sha256": rec.sha256[:12],
                "format": rec.format,
                "rows": rec.rows,
                "parts": int(mine["part"].fillna("").nunique()),
                "first": str(stamps.min()) if len(stamps) else "",
                "last": str(stamps.max()) if len(stamps) else "",
                "imported": rec.imported_at,
                "excluded": rec.excluded,
            }
        )
    log = store.corrections()
    temps = store.temperatures()
    return {
        **summary,
        "machine": store.machine,
        "reports": reports,
        "corrections": int((log["event"] == "correction").sum()),
        "tool_changes": int((log["event"] == "tool_change").sum()),
        "registers": sorted(log["register"].unique().tolist()),
        "temperature_samples": len(temps),
        "temperature_channels": [c for c in temps.columns if c != "timestamp"],
        "recommendations": len(store.recommendations()),
    }


def _escaped(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame`` as every history CSV writes it: each text cell through
    :func:`~setupfix.outputs.writers.escape_formulas` (a formula prefixed with ``'``, a control
    character or a non-UTF-8 byte made visible), and each header (a temperature channel's name)
    through the same :func:`~setupfix.outputs.writers.csv_cell`."""
    out = escape_formulas(frame)
    out.columns = [csv_cell(str(c)) for c in out.columns]
    return out


def export_history(
    store: Store,
    table: str,
    target: str | os.PathLike[str],
    *,
    every_machine: bool = False,
    include_excluded: bool = False,
) -> tuple[int, tuple[Note, ...]]:
    """Write one stored table of the handle's machine as its canonical CSV (``-``: standard output); the rows
    written and the notes (what the target format cannot carry, the reports left out).

    ``recommendations`` is the audit trail (:data:`setupfix.store.AUDIT_COLUMNS`, one row per register
    component), of every machine with ``every_machine``; ``dfq`` the measurements as an AQDEF (Q-DAS) file
    for the SPC tools a shop runs (:func:`setupfix.outputs.dfq.export_dfq`).  ``measurements`` and ``dfq``
    leave out the reports marked excluded (a rejected, failed or draft-model report,
    :func:`setupfix.store.excluded_reports`) unless ``include_excluded``, and a note says how many, either
    way.  The store is checked whole first (:meth:`~setupfix.store.Store.verify`): a damaged one is
    refused, never exported in part.
    """
    store.verify()
    notes: tuple[Note, ...] = ()
    if table in ("measurements", "dfq"):
        notes = _excluded_note(store, include_excluded)
    if table == "measurements":
        frame = store.measurements(include_excluded=include_excluded)
        write_canonical_csv(frame[[*CANONICAL_COLUMNS, "reference"]], target)
    elif table in ("corrections", "temperatures", "recommendations"):
        if table == "corrections":
            frame = store.corrections()
        elif table == "temperatures":
            frame = store.temperatures()
        else:
            frame = store.audit(every_machine=every_machine)
        write_table_csv(_escaped(frame), target)
    elif table == "dfq":
        n, written = export_dfq(store, target, include_excluded=include_excluded)
        return n, (*notes, *written)
    else:
        raise ParameterError(f"history export: table must be one of {', '.join(EXPORTS)}, got {table!r}")
    return len(frame), notes


def _excluded_note(store: Store, included: bool) -> tuple[Note, ...]:
    """What an export of the measurements says of the reports marked excluded: how many, why, left out or not."""
    marked = excluded_reports(store)
    if not marked:
        return ()
    why = ", ".join(f"{n} {reason}" for reason, n in sorted(Counter(r.excluded for r in marked).items()))
    if included:
        text = f"{len(marked)} report(s) marked excluded ({why}) taken in (--include-excluded)"
    else:
        text = f"left out {len(marked)} report(s) marked excluded ({why}); --include-excluded takes them in"
    return (Note(text, SourceLocation(store.location), "excluded"),)


def record_recommendations(
    store: Store,
    results: Sequence[CycleCorrection],
    *,
    model: str | os.PathLike[str],
    report: str | os.PathLike[str],
    seed: int | None = None,
    exported: Exported | None = None,
) -> list[int]:
    """Store the recommendations of one ``correct`` run (its cycles), one transaction.

    Inputs kept: the SHA-256 of the model and report files, their names, part and seed, and
    with ``exported`` where the offsets went (file, controller, SHA-256 of the text: the audit's
    ``exported_to``; not ``applied``: a written program is not yet on the machine);
    the result is the ``correct --json`` object of each part.  Returns the stored ids.
    """
    hashes = {k: hashlib.sha256(read_bytes(str(p))).hexdigest() for k, p in (("model", model), ("report", report))}
    ids = []
    with store.transaction():
        for r in results:
            result = cycle_json(r)
            inputs = {
                "model": visible_name(os.fspath(model)),  # printable: a non-UTF-8 or ESC-holding name is escaped
                "model_sha256": hashes["model"],
                "report": visible_name(os.fspath(report)),
                "report_sha256": hashes["report"],
                "part": result.get("part"),
                "seed": seed,
            }
            if exported is not None and r.part.part in exported.parts:
                inputs["export"] = {
                    "target": visible_name(exported.target),
                    "controller": exported.controller,
                    "sha256": exported.sha256,
                }
            ids.append(store.add_recommendation(Recommendation(result["optimizer"], inputs, result)))
    return ids


def record_correction(
    ref: StoreRef,
    model: ProcessModel,
    results: Sequence[CycleCorrection],
    *,
    report: str | os.PathLike[str],
    seed: int | None = None,
    write: Callable[[], Exported | None] = lambda: None,
) -> Exported | None:
    """``correct --store``: the recommendations recorded for the model's machine, and the offsets written.

    ``write`` (the export, if any) runs inside the store's transaction, after the store has taken
    its write lock: a store that cannot take the record (locked, read-only, down) refuses before
    anything is written, and a failed write records nothing.  Should the commit itself fail, the
    written file is removed: a program is on disk only with its audit record in the store.
    """
    exported = None
    try:
        with ref.for_model(model).open() as store, store.transaction():
            exported = write()
            record_recommendations(store, results, model=model.source, report=report, seed=seed, exported=exported)
            mark_report(store, read_bytes(os.fspath(report)), results, draft=model.draft)
    except StoreError:
        if exported is not None and exported.target != "-":
            Path(exported.target).unlink(missing_ok=True)
        raise
    return exported


def mark_report(store: Store, data: bytes, results: Sequence[CycleCorrection], *, draft: bool) -> str | None:
    """Give a report the store holds the mark of this correction (the newest verdict rules); its mark.

    ``correct --store`` stores no report's rows, but a report imported before and now rejected, or
    corrected with a draft model, or not solved, is left out of the history from now on (and one
    corrected cleanly again is taken back in), by the rule batch marks by
    (:func:`setupfix.usecases.batch_records.exclusion`).  A report the store does not hold is left alone.
    """
    sha = hashlib.sha256(data).hexdigest()
    held = store.report(sha)
    mark = exclusion([r.verdict for r in results], [r.solved for r in results], draft=draft)
    if held is not None and held.excluded != mark:
        store.add_report(data, held.name, held.format, store.measurements(sha), excluded=mark)
    return mark


def migrate_history(source: Store, target: Store) -> dict[str, int]:
    """Copy every row of every table of ``source`` (all machines) into the empty store ``target``, one
    transaction; the rows copied per table (each checked equal to the source's count).

    Raises
    ------
    StoreError
        If ``target`` already holds rows (a copy never merges into a store in use), or a table's count
        differs after the copy (nothing is kept then).
    """
    held = [t for t, _, _ in TABLES if target.count(t)]
    if held:
        raise StoreError(
            f"the target store already holds {', '.join(held)} rows: migrate into an empty store",
            location=SourceLocation(target.location),
            hint="give a new database with --db",
        )
    source.verify()
    copied: dict[str, int] = {}
    with target.transaction():
        for table, _, _ in TABLES:
            target.restore(table, source.dump(table))
            copied[table] = target.count(table)
            if copied[table] != source.count(table):
                raise StoreError(
                    f"{table}: {copied[table]} rows copied of {source.count(table)}; nothing kept",
                    location=SourceLocation(target.location),
                )
    return copied
