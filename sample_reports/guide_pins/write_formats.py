"""Write ``cycle_01.qif`` and ``cycle_01.dmo`` from ``cycle_01.csv``.

The same measurements as the canonical CSV, in two real report formats, so that
``setupfix correct`` can be shown on a QIF and a DMIS report:

* QIF 3.0 results, lengths in mm: one ``DistanceBetween`` characteristic per
  dimension (definition → nominal → item → measurement), tolerances as deviations
  (``DefinedAsLimit`` false), one ``MeasurementResults`` per fixture station whose
  actual component carries the cycle and the station as ``AttributeStr`` values.
* DMIS 04.0 output: per dimension a nominal point ``F(name)`` whose Z is the nominal,
  a ``CORTOL,ZAXIS`` tolerance, the actual point ``FA(name)`` and its result
  ``TA(name)`` (deviation and INTOL/OUTOL); ``PARTSN`` names the cycle, ``DATE``/``TIME``
  the machining time, and ``RECALL/D(station)`` the datum system (one per fixture
  station) each block is reported in.

Both carry the cycle's timestamp (QIF ``ReportPreparationDate``, DMIS ``DATE``/``TIME``).
Labels are the model's names, blanks included: strict DMIS labels have none, but the
names must match the model for ``setupfix correct``.

Run: ``python sample_reports/guide_pins/write_formats.py`` (rewrites both files).
"""

from __future__ import annotations

import csv
from pathlib import Path

from lxml import etree

HERE = Path(__file__).resolve().parent
NS = "http://qifstandards.org/xsd/qif3"


def _el(parent: etree._Element, tag: str, text: object | None = None, **attrib: str) -> etree._Element:
    child = etree.SubElement(parent, f"{{{NS}}}{tag}", attrib)
    if text is not None:
        child.text = str(text)
    return child


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def write_qif(rows: list[dict[str, str]], target: Path) -> None:
    """Write the rows as a QIF 3.0 results document."""
    root = etree.Element(f"{{{NS}}}QIFDocument", nsmap={None: NS}, versionQIF="3.0.0")
    units = _el(_el(root, "FileUnits"), "PrimaryUnits")
    linear = _el(units, "LinearUnit")
    _el(linear, "SIUnitName", "meter")
    _el(linear, "UnitName", "mm")
    _el(_el(linear, "UnitConversion"), "Factor", "0.001")
    chars = _el(root, "Characteristics")
    defs = _el(chars, "CharacteristicDefinitions", n=str(len(rows)))
    noms = _el(chars, "CharacteristicNominals", n=str(len(rows)))
    items = _el(chars, "CharacteristicItems", n=str(len(rows)))
    stations = list(dict.fromkeys(r["station"] for r in rows))
    next_id = 1
    item_ids: list[int] = []
    for r in rows:
        d, nm, it = next_id, next_id + 1, next_id + 2
        next_id += 3
        tol = _el(_el(defs, "DistanceBetweenCharacteristicDefinition", id=str(d)), "Tolerance")
        _el(tol, "MaxValue", r["upper"])
        _el(tol, "MinValue", r["lower"])
        _el(tol, "DefinedAsLimit", "false")
        nominal = _el(noms, "DistanceBetweenCharacteristicNominal", id=str(nm))
        _el(nominal, "CharacteristicDefinitionId", d)
        _el(nominal, "TargetValue", r["nominal"])
        item = _el(items, "DistanceBetweenCharacteristicItem", id=str(it))
        _el(item, "Name", r["characteristic"])
        _el(item, "CharacteristicNominalId", nm)
        item_ids.append(it)
    results = _el(root, "Results")
    mset = _el(results, "MeasurementResultsSet", n=str(len(stations)))
    comps = _el(_el(results, "ActualComponentSets", n="1"), "ActualComponentSet", n=str(len(stations)))
    for station in stations:
        mine = [(r, i) for r, i in zip(rows, item_ids, strict=True) if r["station"] == station]
        res_id, comp_id = next_id, next_id + 1
        next_id += 2
        res = _el(mset, "MeasurementResults", id=str(res_id))
        meas = _el(_el(res, "MeasuredCharacteristics"), "CharacteristicMeasurements", n=str(len(mine)))
        failed = False
        for r, item_id in mine:
            ok = float(r["lower"]) <= float(r["deviation"]) <= float(r["upper"])
            failed |= not ok
            m = _el(meas, "DistanceBetweenCharacteristicMeasurement", id=str(next_id))
            next_id += 1
            _el(_el(m, "Status"), "CharacteristicStatusEnum", "PASS" if ok else "FAIL")
            _el(m, "CharacteristicItemId", item_id)
            _el(m, "Value", r["actual"])
        _el(_el(res, "InspectionStatus"), "InspectionStatusEnum", "FAIL" if failed else "PASS")
        _el(_el(res, "ActualComponentIds", n="1"), "Id", comp_id)
        comp = _el(comps, "ActualComponent", id=str(comp_id))
        attrs = _el(comp, "Attributes", n="2")
        _el(attrs, "AttributeStr", name="cycle", value=mine[0][0]["part"])
        _el(attrs, "AttributeStr", name="station", value=station)
        _el(comp, "SerialNumber", f"{mine[0][0]['part']} {station}")
    trace = _el(results, "InspectionTraceability")
    _el(trace, "ReportPreparationDate", rows[0]["timestamp"])
    root.set("idMax", str(next_id - 1))
    target.write_bytes(etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True))


def write_dmo(rows: list[dict[str, str]], target: Path) -> None:
    """Write the rows as DMIS 04.0 output (CRLF lines, as CMMs write them)."""
    stamp = rows[0]["timestamp"]
    lines = [
        f"DMISMN/'{target.name}',04.0",
        "UNITS/MM,ANGDEC",
        f"FILNAM/'{target.name}'",
        f"PARTSN/'{rows[0]['part']}'",
        f"DATE={stamp[:10].replace('-', '/')}",
        f"TIME={stamp[11:19]}",
        "",
    ]
    station = ""
    for r in rows:
        n = r["characteristic"]
        if r["station"] != station:
            station = r["station"]
            lines.append(f"RECALL/D({station})")
        lines += [
            f"OUTPUT/F({n}),T({n})",
            f"F({n})=FEAT/POINT,CART,0,0,{r['nominal']},0,0,1",
            f"T({n})=TOL/CORTOL,ZAXIS,{r['lower']},{r['upper']}",
        ]
    station = ""
    for r in rows:
        n = r["characteristic"]
        if r["station"] != station:
            station = r["station"]
            lines.append(f"RECALL/D({station})")
        ok = float(r["lower"]) <= float(r["deviation"]) <= float(r["upper"])
        lines += [
            f"OUTPUT/FA({n}),TA({n})",
            f"FA({n})=FEAT/POINT,CART,0.0000,0.0000,{r['actual']},0,0,1",
            f"TA({n})=TOL/CORTOL,ZAXIS,{r['deviation']},{'INTOL' if ok else 'OUTOL'}",
        ]
    lines.append("ENDFIL")
    target.write_bytes(("\r\n".join(lines) + "\r\n").encode("utf-8"))


def main() -> None:
    rows = _rows(HERE / "cycle_01.csv")
    write_qif(rows, HERE / "cycle_01.qif")
    write_dmo(rows, HERE / "cycle_01.dmo")


if __name__ == "__main__":
    main()
