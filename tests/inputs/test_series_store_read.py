"""Issue 40, speed of the history read: a store's reports are matched to the model in one pass
(:func:`setupfix.model.measurements.match_reports`) and the reports' coordinates read at once
(:func:`setupfix.inputs.series_assembly.report_coordinates`); both must give exactly what the
per-report path gave.

The per-report path is written here as it was (``match_parts`` on each report's slice of
:func:`setupfix.store.report_tables`, the reference rows dropped; the coordinate loop row by row)
and compared, field for field, over real stored series: the two-station sample (names repeated
across stations, x, y, z columns) and the guide pins, with a report marked rejected, a part reported
twice, a dimension measured twice in one report, a name the model does not know and reference rows.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from pgserver import location, pg_url

from setupfix.core.errors import MatchError
from setupfix.inputs.series import load_series
from setupfix.inputs.series_assembly import report_coordinates
from setupfix.inputs.stores import StoreRef
from setupfix.model import PartMeasurement, ProcessModel, load_model, match_parts, normalise_name
from setupfix.model.measurements import match_reports
from setupfix.store import open_store, report_rows, report_tables
from setupfix.usecases.parse import parse_reports

__all__ = ["location", "pg_url"]

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ("two_station_xyz", "guide_pins")


def stored(location: str, sample: str) -> ProcessModel:
    """The sample's cycles in a store with the awkward cases added; the sample's model."""
    folder = ROOT / "sample_reports" / sample
    paths = sorted(folder.glob("cycle_0*.csv"))
    tables = [parse_reports([p]).table for p in paths]
    for k, t in enumerate(tables):  # coordinates differing by report: which report gives them matters
        t["x"], t["y"], t["z"] = 100.0 * k + np.arange(len(t)), 2.0 * np.arange(len(t)) + 0.5, -float(k)
    with open_store(location, machine="M") as store, store.transaction():
        for p, t in zip(paths, tables, strict=True):
            store.add_report(p.read_bytes(), p.name, "canonical", t)
        # the first cycle again under another name (one part reported twice), its first row unreadable in x
        again = tables[0].copy()
        again.loc[again.index[0], "x"] = np.nan if "x" in again else None
        store.add_report(b"again", "again.csv", "canonical", again)
        # a rejected report: left out unless asked
        bad = tables[1].copy()
        bad["deviation"] = bad["deviation"] + 0.4
        store.add_report(b"bad", "bad.csv", "canonical", bad, excluded="rejected")
        # one dimension measured twice (the later wins, with a note), a name the model does not know,
        # and a reference row
        odd = tables[-1].copy()
        twice = odd.iloc[[2]].copy()
        twice["deviation"] = twice["deviation"] + 0.001
        twice["timestamp"] = (pd.Timestamp(str(twice["timestamp"].iloc[0])) + pd.Timedelta(minutes=5)).isoformat()
        unknown = odd.iloc[[3]].copy()
        unknown["characteristic"] = "P9 nowhere"
        reference = odd.iloc[[4]].copy()
        reference["reference"] = True
        odd["reference"] = False
        twice["reference"] = unknown["reference"] = False
        store.add_report(b"odd", "odd.csv", "canonical", pd.concat([odd, twice, unknown, reference], ignore_index=True))
    return load_model(folder / "model.toml")


def same(a: PartMeasurement, b: PartMeasurement) -> None:
    for f in dataclasses.fields(PartMeasurement):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            assert x is not None and y is not None, f.name
            assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True), f.name
        else:
            assert x == y, f.name


@pytest.mark.parametrize("sample", SAMPLES)
@pytest.mark.parametrize("include_excluded", [False, True])
def test_one_pass_matches_each_stored_report_as_before(location: str, sample: str, include_excluded: bool) -> None:
    model = stored(location, sample)
    with open_store(location, machine="M") as store:
        old = [
            match_parts(model, t[~t["reference"]], source=f"db#{rec.name}")
            for rec, t in report_tables(store, include_excluded=include_excluded)
        ]
        records, rows, starts = report_rows(store, include_excluded=include_excluded)
    measured = ~rows["reference"].to_numpy(dtype=bool)
    new = match_reports(model, rows[measured], np.r_[0, np.cumsum(measured)][starts], [f"db#{r.name}" for r in records])
    cycles = len(list((ROOT / "sample_reports" / sample).glob("cycle_0*.csv")))
    assert len(old) == len(new) == cycles + 2 + include_excluded  # the copy, the odd one, the rejected one
    notes = 0
    for a_parts, b_parts in zip(old, new, strict=True):
        assert len(a_parts) == len(b_parts)
        for a, b in zip(a_parts, b_parts, strict=True):
            same(a, b)
            notes += len(a.notes)
    assert notes >= 1  # the dimension measured twice was seen
    assert any(p.unmatched == ("P9 nowhere",) for ps in new for p in ps)


def test_a_stored_report_of_reference_rows_only_is_refused_by_name(tmp_path: Path) -> None:
    model = load_model(ROOT / "sample_reports" / "guide_pins" / "model.toml")
    table = parse_reports([ROOT / "sample_reports" / "guide_pins" / "cycle_01.csv"]).table
    with pytest.raises(MatchError, match="no measured characteristic") as err:
        match_reports(model, table, np.array([0, len(table)]), ["db#a.csv", "db#empty.csv"])
    assert "db#empty.csv" in str(err.value.location)


def coordinates_row_by_row(model: ProcessModel, tables: Sequence[pd.DataFrame]) -> np.ndarray:
    """The coordinate read as it was: each row in turn, the first readable one of a single dimension wins."""
    out = np.full((len(model.dimensions), 3), np.nan)
    for table in tables:
        if not {"x", "y", "z", "characteristic"} <= set(table.columns):
            continue
        for _, row in table.iterrows():
            qs = [q for q, d in enumerate(model.dimensions) if normalise_name(str(row["characteristic"])) in d.keys]
            xyz = np.array([pd.to_numeric(row[c], errors="coerce") for c in "xyz"], dtype=float)
            if len(qs) == 1 and np.isfinite(xyz).all() and np.isnan(out[qs[0]]).all():
                out[qs[0]] = xyz
    return out


def test_coordinates_at_once_are_the_row_by_row_ones(location: str) -> None:
    model = stored(location, "guide_pins")
    with open_store(location, machine="M") as store:
        tables = [t[~t["reference"]] for _, t in report_tables(store, include_excluded=True)]
    first = tables[0].copy()
    first["y"] = first["y"].astype(object)
    first.loc[first.index[:3], "y"] = "n/a"  # unreadable: the next report's rows give these
    first.loc[first.index[3], "characteristic"] = "D1"  # a name of several stations: no location from it
    tables = [first, *tables[1:]]
    expected = coordinates_row_by_row(model, tables)
    assert np.isfinite(expected).all()
    assert expected[0, 0] == 100.0 and expected[4, 0] == 4.0  # the second report's, then the first's
    np.testing.assert_array_equal(report_coordinates(model, tables), expected)
    np.testing.assert_array_equal(report_coordinates(model, [pd.concat(tables)]), expected)


def test_the_series_read_from_a_store_keeps_its_parts(location: str) -> None:
    model = stored(location, "two_station_xyz")
    got = load_series(model, db=StoreRef(location, "M"))
    first = ROOT / "sample_reports" / "two_station_xyz" / "cycle_01.csv"
    assert got.excluded == 1 and got.series.n_cycles == 3  # the copy is one part with its original
    np.testing.assert_array_equal(
        got.series.deviation[0], match_parts(model, parse_reports([first]).table)[0].deviation
    )
