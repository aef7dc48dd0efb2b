"""Every writer of setupfix.outputs.writers: write → read gives the same content back."""

from __future__ import annotations

import csv
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from parsers.canonical import read_canonical
from setupfix.core.errors import ExportError, ParseError
from setupfix.model import CANONICAL_COLUMNS, load_model
from setupfix.outputs.writers import (
    check_target,
    write_bytes,
    write_canonical_csv,
    write_figure,
    write_offsets_csv,
    write_text,
)
from setupfix.usecases.correct import correct_report
from setupfix.usecases.export import cycle_rows
from setupfix.usecases.parse import parse_reports
from setupfix.usecases.requests import CorrectRequest

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"


def test_offsets_csv_round_trip(tmp_path: Path) -> None:
    result = correct_report(CorrectRequest(load_model(GUIDE / "model.toml")), GUIDE / "cycle_01.csv").cycles[0]
    rows = cycle_rows(result)
    write_offsets_csv(rows, tmp_path / "off.csv")
    with open(tmp_path / "off.csv", newline="", encoding="utf-8") as stream:
        back = list(csv.DictReader(stream))
    assert [r["id"] for r in back] == [r.id for r in rows]
    assert [float(r["delta"]) for r in back] == [r.delta for r in rows]
    deltas = {r["id"]: float(r["delta"]) for r in back}
    for key, value in result.corrections.items():
        assert deltas.get(key, 0.0) == pytest.approx(value, abs=1e-12)


def test_canonical_csv_round_trip(tmp_path: Path) -> None:
    table = parse_reports([GUIDE / "cycle_01.qif"]).table
    write_canonical_csv(table, tmp_path / "c.csv")
    back = read_canonical(tmp_path / "c.csv")
    assert len(back) == len(table)
    for col in CANONICAL_COLUMNS:
        if pd.api.types.is_numeric_dtype(table[col]):
            np.testing.assert_allclose(back[col].to_numpy(float), table[col].to_numpy(float), rtol=1e-11, atol=0)
        elif col != "source":  # the reader records where it read each row (the new file and line)
            assert back[col].fillna("").astype(str).tolist() == table[col].fillna("").astype(str).tolist(), col


def test_canonical_reference_flag_round_trip(tmp_path: Path) -> None:
    table = parse_reports([GUIDE / "cycle_01.qif"]).table
    table.loc[table.index[0], "reference"] = True  # both values present, so a swap or a constant would fail
    write_canonical_csv(table, tmp_path / "c.csv")
    back = read_canonical(tmp_path / "c.csv")["reference"].tolist()
    assert back == table["reference"].tolist() and all(type(v) is bool for v in back)


def test_canonical_reference_flag_refuses_other_text(tmp_path: Path) -> None:
    (tmp_path / "c.csv").write_text("characteristic,nominal,actual,reference\nD1,25,25.01,maybe\n")
    with pytest.raises(ParseError, match=r"c.csv:2: column 'reference'"):
        read_canonical(tmp_path / "c.csv")


@pytest.mark.slow
@pytest.mark.parametrize("suffix", [".png", ".svg"])
def test_figure_round_trip(tmp_path: Path, suffix: str) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2, 1))
    fig.add_subplot().plot([0, 1], [1, 0])
    write_figure(fig, tmp_path / f"f{suffix}")
    data = (tmp_path / f"f{suffix}").read_bytes()
    if suffix == ".png":
        from matplotlib.image import imread

        assert imread(tmp_path / "f.png").shape[:2] == (120, 240)  # 2 × 1 inch at 120 dpi
    else:
        assert ET.fromstring(data).tag.endswith("svg")


def test_figure_unknown_suffix_or_bad_target_refused_before_drawing(tmp_path: Path) -> None:
    with pytest.raises(ExportError, match="not supported"):
        write_figure(None, tmp_path / "f.pdf")  # type: ignore[arg-type]
    (tmp_path / "d.png").mkdir()
    with pytest.raises(ExportError, match="folder"):
        write_figure(None, tmp_path / "d.png")  # type: ignore[arg-type]


def test_text_and_bytes_round_trip_and_stdout(tmp_path: Path, capsysbinary: pytest.CaptureFixture[bytes]) -> None:
    write_text(tmp_path / "t.txt", "ä\r\nb\n")
    assert (tmp_path / "t.txt").read_bytes() == "ä\r\nb\n".encode()
    write_bytes(tmp_path / "b.bin", bytes(range(256)))
    assert (tmp_path / "b.bin").read_bytes() == bytes(range(256))
    write_bytes("-", b"out")
    assert capsysbinary.readouterr().out == b"out"
    assert check_target("-") is None
