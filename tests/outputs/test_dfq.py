"""The DFQ writer: stored measurements → AQDEF → back through setupfix's Q-DAS reader and through aqdefreader."""

from __future__ import annotations

import math
from datetime import datetime
from pathlib import Path

import pandas as pd
import pytest
from spc_examples import closed_loop_store

from parsers.qdas import read_aqdef
from parsers.timestamps import utc_naive
from setupfix.core.errors import ExportError
from setupfix.outputs.dfq import dfq_text, export_dfq, write_dfq
from setupfix.store import open_store
from setupfix.usecases.history import ImportRequest, import_history


def stored(db: Path) -> pd.DataFrame:
    with open_store(db) as store:
        return store.measurements()


def by_key(table: pd.DataFrame) -> pd.DataFrame:
    return table.sort_values(["characteristic", "part"], kind="stable").reset_index(drop=True)


def assert_round_trip(original: pd.DataFrame, back: pd.DataFrame) -> None:
    a, b = by_key(original), by_key(back)
    assert len(a) == len(b)
    assert list(a["characteristic"]) == list(b["characteristic"])
    assert list(a["part"]) == list(b["part"])
    assert list(a["nominal"]) == list(b["nominal"])  # bit for bit
    assert list(a["actual"]) == list(b["actual"])
    for side in ("lower", "upper"):  # K2110/K2111 − K2101 as the reader takes it: within a rounding of the nominal
        for x, y, nominal in zip(a[side], b[side], a["nominal"], strict=True):
            assert (math.isnan(x) and math.isnan(y)) or abs(x - y) <= 4e-16 * max(1.0, abs(nominal)), (side, x, y)
    times = [datetime.fromisoformat(t).replace(tzinfo=None) if t else None for t in a["timestamp"]]
    assert [datetime.fromisoformat(t) if t else None for t in b["timestamp"]] == times


def test_the_closed_loop_store_reads_back_through_setupfix_s_reader(tmp_path: Path) -> None:
    db = closed_loop_store(tmp_path)
    table = stored(db)
    out = tmp_path / "history.dfq"
    with open_store(db) as store:
        n, notes = export_dfq(store, out)
    assert n == len(table) == 1120
    assert [n.message for n in notes] == [
        "station(s) P1, P2, P3, P4 are not nest numbers (K0007 holds a whole number): left out"
    ]
    back = read_aqdef(out)
    assert_round_trip(table, back)
    text = out.read_text(encoding="utf-8")
    assert text.startswith("K0100 28\nK1001/1 setupfix\n")
    assert "K2112/1 -0.1\nK2111/1 25.1\nK2113/1 0.1\n" in text


def odd_report(folder: Path) -> Path:
    """Dates whose day is past 12 (unambiguous to a month-first reader), numeric stations, one-sided and
    tiny and long numbers, a time with an offset."""
    rows = [
        "characteristic,nominal,actual,lower,upper,part,timestamp,station",
        "Bore A,0,0.00001,-0.00005,0.00005,s1,2026-03-14T07:00:00,1",
        "Bore A,0,-0.0000123,-0.00005,0.00005,s2,2026-03-15T07:30:15,2",
        "Flat,1234.56789012345,1234.5679012345678,,0.02,s1,2026-03-14T07:00:00,1",
        "Flat,1234.56789012345,1234.5601,,0.02,s2,2026-03-15T07:30:15,2",
        "Len,40,40.0123,-0.05,0.05,s3,2026-03-16T09:00:00+02:00,1",
    ]
    path = folder / "odd.csv"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_tiny_long_one_sided_values_and_offsets(tmp_path: Path) -> None:
    db = tmp_path / "odd.db"
    with open_store(db) as store:
        import_history(store, ImportRequest(reports=(odd_report(tmp_path),)))
    table = stored(db)
    text, notes = dfq_text(table)
    assert "e-" not in text and "E-" not in text  # plain decimals
    assert [n.message for n in notes] == ["times with a UTC offset are written in UTC (K0004 holds no offset)"]
    out = tmp_path / "odd.dfq"
    write_dfq(table, out)
    back = read_aqdef(out)
    utc = table.copy()
    utc["timestamp"] = [t.replace("09:00:00+02:00", "07:00:00") for t in utc["timestamp"]]
    assert_round_trip(utc, back)
    assert sorted(back["station"]) == ["1", "1", "1", "2", "2"]
    assert by_key(back)["lower"].isna()[2]  # Flat: no lower limit


def test_aqdefreader_reads_every_value(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    aqdefreader = pytest.importorskip("aqdefreader", reason="aqdefreader (PyPI) is not installed")
    db = tmp_path / "odd.db"
    with open_store(db) as store:
        import_history(store, ImportRequest(reports=(odd_report(tmp_path),)))
    table = stored(db)
    out = tmp_path / "odd.dfq"
    write_dfq(table, out)
    # its DfqFile parser on the file's lines (read_dfq_file leaves the file open: a ResourceWarning here)
    dfq = aqdefreader.DfqFile(out.read_text(encoding="utf-8").splitlines())
    capsys.readouterr()  # it prints what it finds
    chars = dfq.get_part(0).get_characteristics()
    assert [c.get_data("K2002") for c in chars] == ["Bore A", "Flat", "Len"]
    for char in chars:
        rows = table[table["characteristic"] == char.get_data("K2002")]
        assert float(char.get_data("K2101")) == rows["nominal"].iloc[0]
        values = [float(m.value) for m in char.get_measurements()]
        assert values == list(rows["actual"])  # bit for bit, in time order
        stamps = [m.datetime for m in char.get_measurements()]
        assert stamps == [utc_naive(datetime.fromisoformat(t)) for t in rows["timestamp"]]


@pytest.mark.parametrize("name", ["two\nlines", "tab\tin", "shift\x0fin"])
def test_a_name_that_cannot_be_one_field_is_refused(name: str) -> None:
    table = pd.DataFrame(
        {
            "characteristic": [name],
            "nominal": [1.0],
            "actual": [1.1],
            "deviation": [0.1],
            "lower": [-0.2],
            "upper": [0.2],
            "part": ["p"],
            "report": ["r"],
            "timestamp": [""],
            "station": [""],
        }
    )
    with pytest.raises(ExportError, match="control character"):
        dfq_text(table, "t")
