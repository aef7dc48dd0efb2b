"""QIF rows keep their feature: nominal and actual position, own direction, name, datums (issue 39),
and the measurement's uncertainty (issue 40).

The expected values are read from the XML here, with XPath on local names, not through the
reader's code: measurement (``#id`` of the row's source) → its ``FeatureActualIds`` /
``FeatureMeasurementIds`` (else its item's ``FeatureItemIds`` measured in the same results) →
feature item → ``FeatureNominalId`` → ``Location`` | ``Axis/AxisPoint`` | ``CenterLine/StartPoint``.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import SAMPLES, SHARED
from lxml import etree

import parsers
from setupfix.core.errors import ParseError
from setupfix.model.measurements import OPTIONAL_LENGTH_COLUMNS

QIF_FILES = sorted(
    {
        p.name: p for p in [*(SHARED / "cmm-samples" / "qif").glob("*.[qQ][iI][fF]"), *(SAMPLES / "qif").glob("*")]
    }.values()
)
COVER = SHARED / "cmm-samples" / "qif" / "NIST_MTC_Incoming_CoverResults_20_samples.QIF"
BOX = SHARED / "cmm-samples" / "qif" / "NIST_MTC_FAIR_Box_Results_19parts.qif"


def _read(path: Path) -> pd.DataFrame:
    return parsers.read_report(path).table


def _one(node: etree._Element, path: str) -> list[etree._Element]:
    found: list[etree._Element] = node.xpath(path)
    return found


def _words(node: etree._Element | None, path: str) -> list[str]:
    if node is None:
        return []
    found = _one(node, path)
    return (found[0].text or "").split() if found else []


def _mm(root: etree._Element) -> float | None:
    """mm per file unit (mm and inch files only; None for others, which the property skips)."""
    name = _words(
        root,
        "//*[local-name()='FileUnits']/*[local-name()='PrimaryUnits']/*[local-name()='LinearUnit']/*[local-name()='UnitName']",
    )
    unit = name[0].lower() if name else "mm"
    return {"mm": 1.0, "millimeter": 1.0, "millimetre": 1.0, "inch": 25.4, "in": 25.4}.get(unit)


_POSITION = (
    "(*[local-name()='Location'] | *[local-name()='Axis']/*[local-name()='AxisPoint']"
    " | *[local-name()='CenterLine']/*[local-name()='StartPoint'])"
)


def _features(
    root: etree._Element, measurement: etree._Element
) -> list[tuple[etree._Element | None, etree._Element | None]]:
    """(feature item, actual feature) of each feature a measurement is of, in order."""
    by_id = {el.get("id"): el for el in root.iter() if isinstance(el.tag, str) and el.get("id") is not None}
    ids = [
        (i.text or "").strip()
        for i in _one(
            measurement,
            "*[local-name()='FeatureActualIds' or local-name()='FeatureMeasurementIds']/*[local-name()='Id']",
        )
    ]
    results = _one(measurement, "ancestor::*[local-name()='MeasurementResults'][1]")[0]
    if ids:
        out = []
        for i in ids:
            actual = by_id.get(i)
            item_id = _words(actual, "*[local-name()='FeatureItemId']") if actual is not None else []
            out.append((by_id.get(item_id[0]) if item_id else None, actual))
        return out
    item = by_id.get((_one(measurement, "*[local-name()='CharacteristicItemId']")[0].text or "").strip())
    out = []
    for ref in _one(item, "*[local-name()='FeatureItemIds']/*[local-name()='Id']") if item is not None else []:
        fid = (ref.text or "").strip()
        actual = _one(results, f"*[local-name()='MeasuredFeatures']//*[*[local-name()='FeatureItemId'] = '{fid}']")
        out.append((by_id.get(fid), actual[0] if actual else None))
    return out


def _point(words: list[str], scale: float) -> tuple[float, float, float] | None:
    if len(words) != 3:
        return None
    return (float(words[0]) * scale, float(words[1]) * scale, float(words[2]) * scale)


@pytest.mark.slow
@pytest.mark.parametrize("path", QIF_FILES, ids=[p.name for p in QIF_FILES])
def test_every_qif_position_is_the_xmls(path: Path) -> None:
    """Property over every real QIF sample: each row's nominal and actual position, feature name and
    direction equal what the XML states for the measurement's own feature (read here by XPath)."""
    try:
        table = _read(path)
    except ParseError:
        pytest.skip("refused on purpose (tests/parsers/test_golden.py REFUSED)")
    root = etree.parse(str(path)).getroot()
    scale = _mm(root)
    if scale is None:
        pytest.skip("a file unit this property does not convert")
    by_id = {el.get("id"): el for el in root.iter() if isinstance(el.tag, str) and el.get("id") is not None}
    checked = 0
    for row in table.to_dict("records"):
        source = str(row["source"])
        if "#" not in source:
            continue
        measurement = by_id[source.rpartition("#")[2]]
        features = _features(root, measurement)
        if not features:
            assert row["feature_id"] == "" and row["between"] == "" and math.isnan(float(row["x_actual"]))
            continue
        names = [
            (_words(item, "*[local-name()='FeatureName']") or [f"#{item.get('id')}"])[0]
            for item, _ in features
            if item is not None
        ]
        if len(features) == 1:
            assert (row["feature_id"], row["between"]) == (names[0], ""), source
        else:
            assert (row["feature_id"], row["between"]) == ("", ";".join(names)), source
        item, actual = features[0]
        assert item is not None
        nominal = by_id.get(_words(item, "*[local-name()='FeatureNominalId']")[0])
        assert nominal is not None, source
        normal = _words(nominal, "*[local-name()='Normal']")
        if normal and abs(math.dist([float(v) for v in normal], [0, 0, 0]) - 1) > 1e-3:
            # Location and Normal swapped by the writer (QIF2.x_Results_Sample circles): no position
            assert math.isnan(float(row["x"])) and math.isnan(float(row["x_actual"])), source
            continue
        expected = _point(_words(nominal, _POSITION), scale)
        got = (row["x"], row["y"], row["z"])
        if expected is None:
            assert all(math.isnan(float(v)) for v in got), source
        else:
            assert got == pytest.approx(expected, rel=1e-12, abs=1e-12), source
        measured = _point(_words(actual, _POSITION), scale) if actual is not None else None
        got = (row["x_actual"], row["y_actual"], row["z_actual"])
        if measured is None:
            assert all(math.isnan(float(v)) for v in got), source
        else:
            assert got == pytest.approx(measured, rel=1e-12, abs=1e-12), source
        axis = _words(nominal, "*[local-name()='Axis']/*[local-name()='Direction']") or normal
        if axis and not str(nominal.tag).endswith("LineFeatureNominal"):
            vector = np.array([float(v) for v in axis])
            assert (row["feature_nx"], row["feature_ny"], row["feature_nz"]) == pytest.approx(
                tuple(vector / np.linalg.norm(vector)), abs=1e-12
            ), source
        checked += 1
    features_in_file = bool(root.xpath("//*[local-name()='FeatureItemIds' or local-name()='FeatureActualIds']"))
    assert checked > 0 or not features_in_file, "a file with features gave no row to check"


@pytest.mark.skipif(not COVER.is_file(), reason="the NIST cover lives in ../shared")
def test_nist_cover_rows_with_features_get_the_xml_positions() -> None:
    """Issue 39 "Done when" #1 on the cover: each of its 461 measurements with a feature has the
    nominal and actual position of that feature, and the four holes DIAMETER2 is measured on differ."""
    table = _read(COVER)
    root = etree.parse(str(COVER)).getroot()
    with_features = root.xpath("//*[local-name()='CharacteristicActuals']/*[*[local-name()='FeatureActualIds']]")
    assert len(with_features) == 461
    assert table["x_actual"].notna().sum() == 461 and table["x"].notna().sum() == 461
    first = table[table["part"] == table["part"].iloc[0]]
    holes = first[first["characteristic"].str.match(r"^DIAMETER2( \(\d\))?$")]
    got = [v for xy in sorted(zip(holes["x"], holes["y"], strict=True)) for v in xy]
    expected = [v for xy in sorted([(146.9, 5.5), (5.5, 96.1), (146.9, 96.1), (5.5, 5.5)]) for v in xy]
    assert got == pytest.approx(expected, abs=1e-9)
    row = first[first["characteristic"] == "DIAMETER2"].iloc[0]
    assert (row["x_actual"], row["y_actual"], row["z_actual"]) == (146.916, 5.548, 5.4)
    assert (row["feature_nx"], row["feature_ny"], row["feature_nz"]) == (0.0, 0.0, -1.0)
    assert row["feature_id"] == "CYLINDER1"
    position = first[first["characteristic"] == "POSITION2"].iloc[0]
    assert (position["feature_id"], position["datums"]) == ("CYLINDER3", "A|B")
    assert first[first["characteristic"] == "PERPENDICULARITY1"].iloc[0]["datums"] == "A"


@pytest.mark.skipif(not BOX.is_file(), reason="the NIST box lives in ../shared")
def test_nist_box_has_no_features_so_no_positions() -> None:
    """The FAIR box results name no feature at all: its rows stay without positions, never guessed."""
    root = etree.parse(str(BOX)).getroot()
    assert not root.xpath("//*[contains(local-name(), 'Feature')]")
    table = _read(BOX)
    assert table["x"].isna().all() and "x_actual" in table and table["x_actual"].isna().all()
    assert (table["feature_id"] == "").all() and (table["between"] == "").all()


QIF3 = SAMPLES / "qif" / "QIF3_Results_Sample.QIF"


def test_a_distance_keeps_the_features_it_is_between_in_order() -> None:
    table = _read(QIF3)
    row = table[table["characteristic"] == "DIST1"].iloc[0]
    assert (row["feature_id"], row["between"]) == ("", "HOLE2;HOLE1")
    assert table[table["characteristic"] == "7"].iloc[0]["datums"] == "A|B|C"


def _with_uncertainty(tmp_path: Path, attribute: str, unit: str = "") -> Path:
    """QIF3_Results_Sample with ``combinedUncertainty`` on the value of measurement 51 (characteristic 6)."""
    text = QIF3.read_text(encoding="utf-8")
    head, sep, tail = text.partition('<DiameterCharacteristicMeasurement id="51">')
    assert sep
    linear = f' linearUnit="{unit}"' if unit else ""
    tail = re.sub(
        r"<Value>([^<]*)</Value>", rf'<Value combinedUncertainty="{attribute}"{linear}>\1</Value>', tail, count=1
    )
    path = tmp_path / "with_u.QIF"
    path.write_text(head + sep + tail, encoding="utf-8")
    return path


def test_uncertainty_is_twice_the_combined_uncertainty_in_mm(tmp_path: Path) -> None:
    table = _read(_with_uncertainty(tmp_path, "0.0015"))
    row = table[table["source"].str.endswith("#51")].iloc[0]
    assert row["uncertainty"] == pytest.approx(0.003, abs=1e-15)
    assert table.loc[~table["source"].str.endswith("#51"), "uncertainty"].isna().all()
    assert _read(QIF3)["uncertainty"].isna().all()


def test_uncertainty_follows_the_values_own_unit(tmp_path: Path) -> None:
    table = _read(_with_uncertainty(tmp_path, "0.0001", unit="inch"))
    row = table[table["source"].str.endswith("#51")].iloc[0]
    assert row["uncertainty"] == pytest.approx(2 * 0.0001 * 25.4, rel=1e-12)


@pytest.mark.parametrize("bad", ["-0.001", "abc"])
def test_a_bad_combined_uncertainty_is_one_line_at_its_element(tmp_path: Path, bad: str) -> None:
    path = _with_uncertainty(tmp_path, bad)
    with pytest.raises(ParseError) as caught:
        _read(path)
    message = str(caught.value)
    assert "combinedUncertainty" in message and "with_u.QIF" in message and "id=51" in message
    assert "\n" not in message


@pytest.mark.skipif(not COVER.is_file(), reason="the NIST cover lives in ../shared")
def test_a_feature_id_pointing_nowhere_leaves_the_row_without_features(tmp_path: Path) -> None:
    """Hostile: FeatureActualIds naming no element. The row is read, its feature columns and position
    are empty (not the item's first hole), a note says so; the other rows are unchanged."""
    text = COVER.read_text(encoding="utf-8")
    # DiameterCharacteristicActual 35 (DIAMETER2 (2) of the first part) names actual 34
    old = '<DiameterCharacteristicActual id="35">'
    head, sep, tail = text.partition(old)
    tail = tail.replace("<Id>34</Id>", "<Id>999999</Id>", 1)
    path = tmp_path / COVER.name
    path.write_text(head + sep + tail, encoding="utf-8")
    result = parsers.read_report(path)
    table, clean = result.table, _read(COVER)
    broken = table["source"].str.endswith("#35")
    assert broken.sum() == 1
    row = table[broken].iloc[0]
    assert row["feature_id"] == "" and math.isnan(row["x"]) and math.isnan(row["x_actual"])
    assert row["actual"] == clean[broken]["actual"].iloc[0]
    assert any("point nowhere" in str(n) for n in result.notes)
    pd.testing.assert_frame_equal(
        table[~broken].drop(columns="source").reset_index(drop=True),
        clean[~broken].drop(columns="source").reset_index(drop=True),
    )


def test_parse_output_keeps_the_new_columns_and_the_csv_reads_them_back(tmp_path: Path) -> None:
    """`parse` writes the geometry and U columns; reading its CSV back gives the same numbers, and an
    inch row's optional lengths are converted like its nominal."""
    from setupfix.outputs.writers import write_canonical_csv
    from setupfix.usecases.parse import parse_reports

    table = parse_reports([_with_uncertainty(tmp_path, "0.0015")]).table
    for col in ("x_actual", "feature_nx", "feature_id", "between", "datums", "uncertainty"):
        assert col in table.columns
    out = tmp_path / "out.csv"
    write_canonical_csv(table, out)
    back = parsers.read_report(out).table
    for col in OPTIONAL_LENGTH_COLUMNS:
        np.testing.assert_allclose(back[col].to_numpy(dtype=float), table[col].to_numpy(dtype=float), rtol=1e-9)
    assert back["between"].tolist() == table["between"].tolist()
    inch = tmp_path / "inch.csv"
    inch.write_text(
        "characteristic,nominal,actual,unit,x_actual,uncertainty\nA,1,1.001,inch,2,0.0001\n", encoding="utf-8"
    )
    row = parsers.read_report(inch).table.iloc[0]
    assert (row["x_actual"], row["uncertainty"]) == pytest.approx((50.8, 0.00254))


def test_a_negative_uncertainty_in_a_csv_is_refused_with_its_line(tmp_path: Path) -> None:
    path = tmp_path / "neg.csv"
    path.write_text("characteristic,nominal,actual,uncertainty\nA,1,1.001,0.001\nB,1,1.0,-0.002\n", encoding="utf-8")
    with pytest.raises(ParseError, match=r"neg\.csv:3.*uncertainty -0\.002 is negative"):
        parsers.read_report(path)


PLATE = SHARED / "cmm-samples" / "qif" / "NIST_MTC_Incoming_PlateResults_20_samples.QIF"


@pytest.mark.parametrize("path", [COVER, PLATE, BOX], ids=lambda p: p.name)
def test_callout_says_what_the_qif_characteristic_type_is(path: Path) -> None:
    """``callout`` is "distance" for a DistanceBetween characteristic and "position" for a Position one, counted
    per part against the XML's own measurement elements (a DistanceFrom is a location: no callout)."""
    table = _read(path)
    root = etree.parse(str(path)).getroot()
    results = root.xpath("//*[local-name()='MeasurementResults']")
    assert len(results) == table["part"].nunique()
    for word, tag in (
        ("distance", "DistanceBetweenCharacteristicActual"),
        ("position", "PositionCharacteristicActual"),
    ):
        per_part = table[table["callout"] == word].groupby("part", sort=False).size()
        in_xml = [len(r.xpath(f".//*[local-name()='{tag}']")) for r in results]
        assert sorted(per_part.reindex(table["part"].unique(), fill_value=0).tolist()) == sorted(in_xml), word
    assert set(table["callout"].unique()) <= {"", "distance", "position"}
