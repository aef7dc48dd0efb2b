"""PiWeb REST JSON reader on the ZEISS PiWeb-Api samples (BSD-3-Clause, copied)."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from goldens import GOLDEN, assert_golden

import parsers
from parsers.piweb import read_piweb
from setupfix.core.errors import ParseError

SAMPLES = Path(__file__).resolve().parents[2] / "sample_reports" / "piweb"


@pytest.fixture(scope="module")
def values() -> pd.DataFrame:
    return parsers.read_report(SAMPLES / "PiWebApi_sample_values.json").table


def test_values_file_first_measurements_match_golden(values: pd.DataFrame) -> None:
    # The whole table is 27 000 rows; the golden holds the first two measurements (90 rows).
    assert_golden(values.iloc[:90], GOLDEN / "piweb_PiWebApi_sample_values_first2.csv", str(SAMPLES) + "/")


def test_values_file_shape_and_totals(values: pd.DataFrame) -> None:
    assert parsers.find_format(SAMPLES / "PiWebApi_sample_values.json").name == "piweb"
    assert len(values) == 600 * 45 and values["part"].nunique() == 600
    raw = json.loads((SAMPLES / "PiWebApi_sample_values.json").read_text(encoding="utf-8-sig"))
    total = sum(v["1"] for m in raw for v in m["characteristics"].values())
    assert values["actual"].sum() == pytest.approx(total)
    # Nominal 0 and absolute limits -0.15/0.3 (2110/2111) for Y-Wert_Kreis1.
    row = values[values["characteristic"] == "Y-Wert_Kreis1"].iloc[0]
    assert (row["nominal"], row["lower"], row["upper"]) == (0.0, -0.15, 0.3)
    assert set(values["station"]) <= {"1", "2", "3", "4", ""} and values["timestamp"].str.endswith("Z").all()


@pytest.mark.parametrize(
    "name, reason",
    [
        ("PiWebApi_sample_characteristics.json", "characteristics"),
        ("PiWebApi_sample_measurements.json", "measurements"),
        ("PiWebApi_sample_parts.json", "parts"),
        ("PiWebApi_sample_configuration.json", "not a PiWeb list"),
    ],
)
def test_files_without_values_are_refused(name: str, reason: str) -> None:
    with pytest.raises(ParseError, match=reason):
        read_piweb(SAMPLES / name)


def test_missing_characteristics_file_and_bad_value(tmp_path: Path) -> None:
    raw = json.loads((SAMPLES / "PiWebApi_sample_values.json").read_text(encoding="utf-8-sig"))[:1]
    path = tmp_path / "x_values.json"
    path.write_text(json.dumps(raw))
    with pytest.raises(ParseError, match=r"x_characteristics.json not found"):
        read_piweb(path)
    (tmp_path / "x_characteristics.json").write_bytes((SAMPLES / "PiWebApi_sample_characteristics.json").read_bytes())
    uuid = next(iter(raw[0]["characteristics"]))
    raw[0]["characteristics"][uuid]["1"] = "n/a"
    path.write_text(json.dumps(raw))
    with pytest.raises(ParseError, match=r"\[\[0\]\.characteristics\.[0-9a-f-]+\]: value 1: expected a number"):
        read_piweb(path)
