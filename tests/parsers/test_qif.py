"""QIF reader: the id chain, tolerance styles, units, parts, external plans, bad input."""

from __future__ import annotations

import math
import shutil
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from goldens import expect_note

import parsers
from parsers.qif import read_qif, sniff_qif
from setupfix.core.errors import ParseError

ROOT = Path(__file__).resolve().parents[2]
QIF = ROOT / "sample_reports" / "qif"


def _row(table: pd.DataFrame, name: str) -> pd.Series[Any]:
    rows = table[table["characteristic"] == name]
    assert len(rows) == 1, f"{name}: {len(rows)} rows"
    return rows.iloc[0]


def qif_doc(
    *,
    units: str = "mm",
    tolerance: str = "<MaxValue>0.2</MaxValue><MinValue>-0.1</MinValue><DefinedAsLimit>false</DefinedAsLimit>",
    target: str = "<TargetValue>40</TargetValue>",
    value: str = "40.05",
    kind: str = "Diameter",
    extra_def: str = "",
) -> str:
    """A minimal QIF 3 results document with one characteristic (id chain 1→2→3, measured as 5)."""
    file_units = (
        ""
        if units == ""
        else (
            f"<FileUnits><PrimaryUnits><LinearUnit><SIUnitName>meter</SIUnitName><UnitName>{units}</UnitName>"
            "</LinearUnit></PrimaryUnits></FileUnits>"
        )
    )
    tol = f"<Tolerance>{tolerance}</Tolerance>" if tolerance else ""
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<QIFDocument xmlns="http://qifstandards.org/xsd/qif3" versionQIF="3.0.0">
  {file_units}
  <Characteristics>
    <CharacteristicDefinitions n="1"><{kind}CharacteristicDefinition id="1">{tol}{extra_def}
    </{kind}CharacteristicDefinition></CharacteristicDefinitions>
    <CharacteristicNominals n="1"><{kind}CharacteristicNominal id="2">
      <CharacteristicDefinitionId>1</CharacteristicDefinitionId>{target}</{kind}CharacteristicNominal>
    </CharacteristicNominals>
    <CharacteristicItems n="1"><{kind}CharacteristicItem id="3"><Name>BORE 1</Name>
      <CharacteristicNominalId>2</CharacteristicNominalId></{kind}CharacteristicItem></CharacteristicItems>
  </Characteristics>
  <Results><MeasurementResultsSet n="1"><MeasurementResults id="4">
    <MeasuredCharacteristics><CharacteristicMeasurements n="1">
      <{kind}CharacteristicMeasurement id="5"><Status><CharacteristicStatusEnum>PASS</CharacteristicStatusEnum>
      </Status><CharacteristicItemId>3</CharacteristicItemId><Value>{value}</Value>
      </{kind}CharacteristicMeasurement>
    </CharacteristicMeasurements></MeasuredCharacteristics>
  </MeasurementResults></MeasurementResultsSet></Results>
</QIFDocument>
"""


def write(tmp_path: Path, text: str, name: str = "r.qif") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_sniffer_recognises_qif_and_rejects_other_xml() -> None:
    assert sniff_qif('<?xml version="1.0"?>\n<QIFDocument xmlns="x">')
    assert not sniff_qif("<?xml version='1.0'?><svg/>")


def test_qif3_sample_follows_the_id_chain() -> None:
    # Checked by hand against QIF3_Results_Sample.QIF: measurement 51 → item 50 ("6") →
    # nominal 49 (TargetValue 10) → definition 48 (±0.4, DefinedAsLimit false).
    table = read_qif(QIF / "QIF3_Results_Sample.QIF")
    bore = _row(table, "6")
    assert (bore["nominal"], bore["actual"], bore["lower"], bore["upper"]) == (10.0, 9.499476, -0.4, 0.4)
    assert bore["deviation"] == pytest.approx(-0.500524)
    assert bore["status"] == "FAIL"
    assert bore["source"].endswith("QIF3_Results_Sample.QIF#51")
    # Point profile, zone 1.5 with OuterDisposition 1 → −0.5 … +1.0; uniform zone 4 → ±2.
    assert (_row(table, "4")["lower"], _row(table, "4")["upper"]) == (-0.5, 1.0)
    assert (_row(table, "5")["lower"], _row(table, "5")["upper"]) == (-2.0, 2.0)
    # Item 15 is measured twice (ids 17, 18): both kept, told apart.
    assert {"5", "5 (2)"} <= set(table["characteristic"])


def test_reference_only_characteristics_are_flagged_without_limits() -> None:
    table = read_qif(QIF / "QIF3_Results_Sample.QIF")
    basic = _row(table, "1")  # NonTolerance MEASURED, status BASIC_OR_TED
    assert basic["reference"] and math.isnan(basic["lower"]) and math.isnan(basic["upper"])
    assert basic["status"] == "BASIC_OR_TED"
    assert table["reference"].sum() == 2


def test_qif2_vocabulary_is_read_like_qif3() -> None:
    q2 = read_qif(QIF / "QIF2.0_Results_Sample.QIF")
    q3 = read_qif(QIF / "QIF3_Results_Sample.QIF")
    assert _row(q2, "6")["actual"] == _row(q3, "6")["actual"]
    assert len(q2) > 5


def test_defined_as_limit_true_becomes_signed_deviations(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        qif_doc(tolerance="<MaxValue>40.2</MaxValue><MinValue>39.9</MinValue><DefinedAsLimit>true</DefinedAsLimit>"),
    )
    row = read_qif(path).iloc[0]
    assert row["lower"] == pytest.approx(-0.1) and row["upper"] == pytest.approx(0.2)
    assert row["deviation"] == pytest.approx(0.05)


def test_one_sided_and_missing_tolerances_stay_empty(tmp_path: Path) -> None:
    one = read_qif(
        write(tmp_path, qif_doc(tolerance="<MaxValue>0.2</MaxValue><DefinedAsLimit>false</DefinedAsLimit>"))
    ).iloc[0]
    assert math.isnan(one["lower"]) and one["upper"] == 0.2
    none = read_qif(write(tmp_path, qif_doc(tolerance=""), "b.qif")).iloc[0]
    assert math.isnan(none["lower"]) and math.isnan(none["upper"])


def test_per_value_linear_unit_overrides_file_units(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        qif_doc(
            units="inch",
            target="<TargetValue>2</TargetValue>",
            value="2.001",
            tolerance='<MaxValue linearUnit="mm">0.05</MaxValue>'
            "<MinValue>-0.002</MinValue><DefinedAsLimit>false</DefinedAsLimit>",
        ),
    )
    row = read_qif(path).iloc[0]
    assert row["nominal"] == pytest.approx(50.8) and row["actual"] == pytest.approx(50.8254)
    assert row["upper"] == pytest.approx(0.05) and row["lower"] == pytest.approx(-0.0508)
    assert row["unit"] == "mm"


def test_missing_file_units_with_evident_mm_warns_and_reads_mm() -> None:
    with expect_note("no FileUnits.*read as mm"):
        table = read_qif(QIF / "NIST_MTC_FAIR_Plate_Results_20parts.qif")
    assert _row(table[table["part"] == "1"], "Diameter 4")["nominal"] == 10.0


def test_missing_file_units_with_small_values_needs_unit(tmp_path: Path) -> None:
    path = write(tmp_path, qif_doc(units="", target="<TargetValue>0.04</TargetValue>", value="0.0401"))
    with pytest.raises(ParseError, match=r"no FileUnits.*--unit"):
        read_qif(path)
    assert read_qif(path, unit="inch").iloc[0]["nominal"] == pytest.approx(0.04 * 25.4)


def test_several_measurement_results_are_parts_named_by_serial() -> None:
    table = read_qif(QIF / "QIF3_SheetMetal_Results_6_samples.QIF")
    assert table["part"].nunique() == 6
    assert table.groupby("part").size().eq(38).all()
    assert table["part"].iloc[0].startswith("SN")


def test_angles_are_skipped_with_a_warning() -> None:
    with expect_note(r"skipped 80 Angle \(not a length\)"):
        table = read_qif(QIF / "NIST_MTC_FAIR_Plate_Results_20parts.qif")
    assert len(table) == 680


def test_negative_zone_is_read_as_its_size_with_a_warning() -> None:
    with expect_note("negative tolerance zone -0.13 read as 0.13"):
        table = read_qif(QIF / "NIST_MTC_Incoming_PlateResults_20_samples.QIF")
    assert (table.loc[table["characteristic"] == "PERPENDICULARITY1", "upper"] == 0.13).all()


def test_limits_without_target_are_skipped_not_guessed(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        qif_doc(
            target="",
            tolerance="<MaxValue>40.2</MaxValue><MinValue>39.9</MinValue><DefinedAsLimit>true</DefinedAsLimit>",
        ),
    )
    with pytest.raises(ParseError, match="no length characteristics"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        read_qif(path)


def test_external_plan_beside_the_results_is_found_by_qpid() -> None:
    table = read_qif(QIF / "QIF3_Exploded_Results1.QIF", unit="mm")
    diameter = _row(table, "SphericalDiameter1")
    assert diameter["nominal"] == pytest.approx(25.4) and diameter["upper"] == 0.25


def test_external_plan_missing_is_a_clear_error(tmp_path: Path) -> None:
    alone = tmp_path / "Exploded_Results1.QIF"
    shutil.copy(QIF / "QIF3_Exploded_Results1.QIF", alone)
    with pytest.raises(ParseError, match=r"external plan '\./Exploded_Plan\.QIF'.*not beside"):
        read_qif(alone, unit="mm")


def test_broken_id_reference_names_the_element(tmp_path: Path) -> None:
    text = qif_doc().replace(
        "<CharacteristicItemId>3</CharacteristicItemId>", "<CharacteristicItemId>99</CharacteristicItemId>"
    )
    with pytest.raises(ParseError, match=r"r\.qif:\d+: <DiameterCharacteristicMeasurement id=5>: .*99"):
        read_qif(write(tmp_path, text))


def test_non_numeric_value_names_the_line(tmp_path: Path) -> None:
    with pytest.raises(ParseError, match=r"r\.qif:\d+: <Value>: expected a number"):
        read_qif(write(tmp_path, qif_doc(value="forty")))


def test_truncated_xml_is_a_parse_error_with_line(tmp_path: Path) -> None:
    text = qif_doc()
    with pytest.raises(ParseError, match=r"r\.qif:\d+: not well-formed XML"):
        read_qif(write(tmp_path, text[: len(text) // 2]))


def test_registry_dispatches_qif_by_content_whatever_the_name(tmp_path: Path) -> None:
    path = write(tmp_path, qif_doc(), "results.xml")
    assert parsers.find_format(path).name == "qif"
    assert np.isclose(parsers.read_report(path).table["deviation"].iloc[0], 0.05)
