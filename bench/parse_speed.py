"""Characteristics parsed per second, per report format.

Run: ``python -m bench.parse_speed > bench/results/parse_speed.txt``

Inputs: the real 20-part NIST QIF file (``sample_reports/qif``), and large files
written here from the guide-pins cycle (``sample_reports/guide_pins/cycle_01.csv``)
repeated as many parts as needed, in each format.  Each timing is the best of
``REPEAT`` runs; ``pandas.read_csv`` of a CSV with the same number of rows is timed
in the same run as a reference, so the ratio is comparable across machines.
"""

from __future__ import annotations

import csv
import functools
import importlib.util
import platform
import tempfile
import time
import warnings
from copy import deepcopy
from pathlib import Path

import openpyxl
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]

import parsers

GUIDE = ROOT / "sample_reports" / "guide_pins"
NIST = ROOT / "sample_reports" / "qif" / "NIST_MTC_FAIR_Plate_Results_20parts.qif"
REPEAT = 5
PARTS = 4000  # × 28 characteristics = 112 000 rows per large file


def _writer_module():
    spec = importlib.util.spec_from_file_location("write_formats", GUIDE / "write_formats.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # type: ignore[union-attr]  # a file spec has a loader
    return module


def _rows(parts: int) -> list[dict[str, str]]:
    with open(GUIDE / "cycle_01.csv", newline="", encoding="utf-8") as handle:
        base = list(csv.DictReader(handle))
    out = []
    for p in range(parts):
        for r in base:
            out.append({**r, "part": f"cycle {p:05d}", "station": f"{r['station']}-{p:05d}"})
    return out


def _best(fn, repeat: int = REPEAT) -> float:
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def _write_inputs(folder: Path, rows: list[dict[str, str]]) -> dict[str, Path]:
    paths = {
        "qif": folder / "big.qif",
        "canonical": folder / "big.csv",
        "table-csv": folder / "big_shop.csv",
        "table-xlsx": folder / "big.xlsx",
        "calypso": folder / "big_chr.txt",
    }
    _write_big_qif(paths["qif"], PARTS // 20)
    with open(paths["canonical"], "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    with open(paths["table-csv"], "w", newline="", encoding="cp1252") as fh:
        fh.write("Merkmal;Sollwert;Istwert;UGW;OGW;Station;Teil\n")
        for r in rows:
            n = float(r["nominal"])
            fh.write(
                f"{r['characteristic']};{r['nominal'].replace('.', ',')};{r['actual'].replace('.', ',')};"
                f"{n + float(r['lower']):.4f};{n + float(r['upper']):.4f};{r['station']};{r['part']}\n"
            )
    book = openpyxl.Workbook(write_only=True)
    sheet = book.create_sheet("CMM")
    sheet.append(["Name", "Nom", "Meas", "Tol", "Part"])
    for r in rows[:20_000]:
        sheet.append([r["characteristic"], float(r["nominal"]), float(r["actual"]), 0.1, r["part"]])
    book.save(paths["table-xlsx"])
    with open(paths["calypso"], "w", encoding="cp1252") as fh:
        fh.write(
            "planid\tpartnb\tid\ttype\tidsymbol\tactual\tnominal\tuppertol\tlowertol\tdeviation\texceed\t"
            "featurePosX\tfeaturePosY\tfeaturePosZ\tunit\n"
        )
        for r in rows:
            fh.write(
                f"Plan\t{r['part']}\t{r['characteristic']}\tLotlänge\tlengthOfAxis\t{r['actual']}\t"
                f"{r['nominal']}\t{r['upper']}\t{r['lower']}\t{r['deviation']}\t\t0\t0\t0\tmm\n"
            )
        fh.write("END\n")  # as CALYPSO ends every table (a file without it is refused as truncated)
    return paths


def _write_big_qif(path: Path, copies: int) -> None:
    """The real NIST 20-part file with its MeasurementResults repeated ``copies`` times:
    real structure (items shared by all parts), ``20 × copies`` parts."""
    from lxml import etree

    root = etree.fromstring(NIST.read_bytes())
    ns = etree.QName(root).namespace
    results = root.find(f"{{{ns}}}MeasurementsResults/{{{ns}}}MeasurementResultsSet")
    originals = list(results)
    for _ in range(copies - 1):
        for element in originals:
            results.append(deepcopy(element))
    path.write_bytes(etree.tostring(root, xml_declaration=True, encoding="utf-8"))


def _write_dmis(folder: Path, rows: list[dict[str, str]]) -> Path:
    # One DMIS output is one part: a large file is many characteristics of one part.
    renamed = [{**r, "characteristic": f"{r['characteristic']} {i:06d}"} for i, r in enumerate(rows)]
    path = folder / "big.dmo"
    _writer_module().write_dmo(renamed, path)
    return path


def main() -> None:
    warnings.simplefilter("ignore")
    rows = _rows(PARTS)
    lines = [
        f"# python -m bench.parse_speed  ({platform.python_version()}, pandas {pd.__version__}, "
        f"{platform.machine()}, best of {REPEAT})",
        "",
    ]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        paths = _write_inputs(folder, rows)
        paths["dmis"] = _write_dmis(folder, rows[: len(rows) // 10])
        reference = _best(lambda: pd.read_csv(paths["canonical"]))
        lines.append(
            f"reference: pandas.read_csv of {len(rows)} rows: {reference:.3f} s ({len(rows) / reference:,.0f} rows/s)"
        )
        lines.append("")
        lines.append(f"{'input':<44}{'rows':>8}{'seconds':>10}{'chars/s':>12}{'x read_csv':>12}")
        cases = [
            ("NIST FAIR Plate QIF 2.1, 20 parts (real)", NIST, {}),
            (f"QIF 2.1, NIST results x{PARTS // 20} ({PARTS} parts)", paths["qif"], {}),
            ("canonical CSV", paths["canonical"], {}),
            ("table CSV (';', decimal comma, CP1252)", paths["table-csv"], {}),
            ("table Excel .xlsx", paths["table-xlsx"], {"columns": "tolerance=Tol"}),
            ("CALYPSO _chr.txt", paths["calypso"], {}),
            ("DMIS .dmo (one part, F/T/FA/TA per row)", paths["dmis"], {}),
        ]
        for label, path, options in cases:
            n = len(parsers.read_report(path, **options).table)
            read = functools.partial(parsers.read_report, path, **options)
            seconds = _best(read, 3 if n > 50_000 else REPEAT)
            ref_rows = reference * n / len(rows)
            lines.append(f"{label:<44}{n:>8}{seconds:>10.3f}{n / seconds:>12,.0f}{seconds / ref_rows:>12.1f}")
    lines += [
        "",
        "targets: NIST 20-part QIF < 0.2 s; QIF and tables >= 100,000 characteristics/s",
        "x read_csv: time relative to pandas.read_csv of the same number of canonical rows",
    ]
    print("\n".join(lines))


if __name__ == "__main__":
    main()
