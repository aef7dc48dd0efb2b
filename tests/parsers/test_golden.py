"""Every real sample of the QIF, DMIS and CALYPSO folders parses to its golden table or is
refused with a reason a person would accept.

Goldens: full canonical CSVs for samples whose licence lets them be copied
(``sample_reports/qif``), per-part summaries of derived numbers for the others
(read from ``../shared``; skipped when it is absent).  After a deliberate change of
reader behaviour, regenerate with ``python tests/parsers/test_golden.py --regenerate``
and review the diff.
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import SHARED as SHARED_ROOT

ROOT = Path(__file__).resolve().parents[2]
GOLDEN = Path(__file__).resolve().parent / "golden"
SHARED_SAMPLES = SHARED_ROOT / "cmm-samples"
COPIED = ROOT / "sample_reports"

#: (golden folder, shared folder, file, kind) — kind "full" needs a copy in sample_reports/qif.
PARSED: list[tuple[str, str, str, str]] = [
    ("qif", "qif", "QIF3_Results_Sample.QIF", "full"),
    ("qif", "qif", "QIF2.0_Results_Sample.QIF", "full"),
    ("qif", "qif", "QIF2.1_Results_Sample.QIF", "full"),
    ("qif", "qif", "QIF3_WIDGET_QIF_RESULTS.QIF", "full"),
    ("qif", "qif", "QIF3_SheetMetal_Results_6_samples.QIF", "full"),
    ("qif", "qif", "QIF3_All-in-one.QIF", "full"),
    ("qif", "qif", "QIF3_Exploded_Results1.QIF", "full"),
    ("qif", "qif", "QIF3_Exploded_Results2.QIF", "full"),
    ("qif", "qif", "QIF3_testPython30.qif", "full"),
    ("qif", "qif", "NIST_MTC_FAIR_Plate_Results_20parts.qif", "full"),
    ("qif", "qif", "NIST_MTC_Incoming_PlateResults_20_samples.QIF", "full"),
    ("qif", "qif", "QIF2.1_WIDGET_QIF_RESULTS.QIF", "summary"),
    ("qif", "qif", "QIF3_PTS_SAMPLE.QIF", "summary"),
    ("qif", "qif", "QIF3_SheetMetal_Results_6_samples_w_UUIDs.QIF", "summary"),
    ("qif", "qif", "QIF3_SheetMetal_Results_sample_1.QIF", "summary"),
    ("qif", "qif", "QIF3_SheetMetal_Results_sample_4.QIF", "summary"),
    ("qif", "qif", "QIF3_WIDGET_QIF_RESULTS_W_QPIDS.QIF", "summary"),
    ("qif", "qif", "NIST_MTC_FAIR_Box_Results_19parts.qif", "summary"),
    ("qif", "qif", "NIST_MTC_Incoming_CoverResults_20_samples.QIF", "summary"),
    ("dmis", "dmis_dmo", "DMO_Example1_PiezaDemo.dmo", "summary"),
    ("dmis", "dmis_dmo", "DMO_Impeller_6_Blades_Part_1.dmo", "summary"),
    ("dmis", "dmis_dmo", "DMO_Impeller_6_Blades_Part_7.dmo", "summary"),
    ("dmis", "dmis_dmo", "DMO_Impeller_6_Blades_Part_33.dmo", "summary"),
    ("calypso", "calypso", "CALYPSO_chr_PruefplanValidierungsbauteil1_16.txt", "summary"),
]

#: Samples refused on purpose, with the reason the message must give.
REFUSED: list[tuple[str, str, str]] = [
    ("qif", "QIF3_WIDGET_QIF_PLAN.QIF", "no measurement results"),
    ("qif", "QIF3_Exploded_Plan.QIF", "no measurement results"),
    ("qif", "MeasurLink_target_New_Test.QIF", "no measurement results"),
    ("qif", "QIF3_mitutoyo_results_serialized_pass_fail_sample.QIF", "no characteristic values"),
    ("qif", "MBDVidia_AerohubHoleBlock_QIF3_inch.qif", "not well-formed XML: xmlns: '##other' is not a valid URI"),
    ("qif", "QIF3_Mixed_Exploded_Results1.QIF", "external plan '.\\Exploded-form_only_Plan.QIF'"),
]

SUMMARY_COLUMNS = [
    "part",
    "rows",
    "with_lower",
    "with_upper",
    "outside",
    "reference",
    "sum_nominal",
    "sum_deviation",
    "min_deviation",
    "max_deviation",
]


def sample_path(folder: str, name: str, kind: str) -> Path:
    """The copy in sample_reports when there is one, else the ../shared file (or skip)."""
    copy = COPIED / "qif" / name
    if kind == "full" or copy.exists():
        assert copy.exists(), f"{name} must be copied into sample_reports/qif (its golden is a full table)"
        return copy
    path = SHARED_SAMPLES / folder / name
    if not path.exists():
        pytest.skip(f"../shared is not beside the project ({path} absent): licence forbids a copy")
    return path


def read_quietly(path: Path) -> pd.DataFrame:
    import parsers

    return parsers.read_report(path).table


def render_full(table: pd.DataFrame) -> str:
    """The canonical table as `setupfix parse` writes it (the ``axis`` column last where the
    reader states axes), provenance reduced to the file name."""
    from setupfix.outputs.writers import FLOAT_FORMAT
    from setupfix.usecases.parse import ParsedReport, ParseOutcome

    table = table.copy()
    table["source"] = table["source"].map(lambda s: Path(str(s)).name)
    written = ParseOutcome(reports=(ParsedReport("", "", table),)).table
    buffer = io.StringIO()
    written.to_csv(buffer, index=False, float_format=FLOAT_FORMAT, lineterminator="\n")
    return buffer.getvalue()


def render_summary(table: pd.DataFrame) -> str:
    """Derived numbers per part: counts, sums and extremes (facts, not the file); the number of
    rows along X, Y and Z where the reader states axes (QIF, DMIS)."""
    out = []
    axes = "axis" in table
    ref = table["reference"] if "reference" in table else pd.Series(False, index=table.index)
    for part, rows in table.groupby(table["part"].astype(str), sort=False):
        dev, lo, up = rows["deviation"], rows["lower"], rows["upper"]
        outside = ((dev < lo) & lo.notna()) | ((dev > up) & up.notna())
        out.append(
            {
                "part": part,
                "rows": len(rows),
                "with_lower": int(lo.notna().sum()),
                "with_upper": int(up.notna().sum()),
                "outside": int(outside.sum()),
                "reference": int(ref[rows.index].astype(bool).sum()),
                "sum_nominal": rows["nominal"].sum(),
                "sum_deviation": dev.sum(),
                "min_deviation": dev.min(),
                "max_deviation": dev.max(),
            }
        )
        if axes:
            out[-1].update({f"axis_{a.lower()}": int((rows["axis"] == a).sum()) for a in "XYZ"})
    buffer = io.StringIO()
    columns = SUMMARY_COLUMNS + (["axis_x", "axis_y", "axis_z"] if axes else [])
    pd.DataFrame(out, columns=columns).to_csv(buffer, index=False, float_format="%.6f", lineterminator="\n")
    return buffer.getvalue()


def golden_file(folder: str, name: str, kind: str) -> Path:
    return GOLDEN / folder / (f"{name}.csv" if kind == "full" else f"{name}.summary.csv")


@pytest.mark.parametrize(("folder", "shared", "name", "kind"), PARSED, ids=[p[2] for p in PARSED])
def test_sample_matches_golden(folder: str, shared: str, name: str, kind: str) -> None:
    path = sample_path(shared, name, kind)
    table = read_quietly(path)
    expected = golden_file(folder, name, kind).read_text(encoding="utf-8")
    rendered = render_full(table) if kind == "full" else render_summary(table)
    assert rendered == expected


@pytest.mark.parametrize(("folder", "name", "reason"), REFUSED, ids=[r[1] for r in REFUSED])
def test_sample_refused_with_reason(folder: str, name: str, reason: str) -> None:
    import parsers
    from setupfix.core.errors import ParseError

    copy = COPIED / "qif" / name
    path = copy if copy.exists() else SHARED_SAMPLES / folder / name
    if not path.exists():
        pytest.skip(f"../shared is not beside the project ({path} absent)")
    with pytest.raises(ParseError) as info:
        parsers.read_report(path).table
    assert reason in str(info.value)
    assert str(info.value).startswith(str(path))


def test_every_shared_sample_of_my_formats_is_covered() -> None:
    """A sample added to ../shared must get a golden or a stated refusal."""
    listed = {p[2] for p in PARSED} | {r[1] for r in REFUSED}
    for folder in ("qif", "dmis_dmo", "calypso"):
        base = SHARED_SAMPLES / folder
        if not base.exists():
            pytest.skip("../shared is not beside the project: nothing to cover")
        for path in base.iterdir():
            if path.suffix.lower() in (".qif", ".dmo") or path.name.endswith("_16.txt") or "_chr_" in path.name:
                assert path.name in listed, f"{path.name} has neither a golden nor a stated refusal"


def test_nist_pair_reports_the_same_parts_with_both_tolerance_styles() -> None:
    """FAIR (absolute limits, no FileUnits) and Incoming (± tolerances, mm) describe the
    same 20 plates: limits come out as signed deviations either way."""
    fair = read_quietly(sample_path("qif", "NIST_MTC_FAIR_Plate_Results_20parts.qif", "full"))
    incoming = read_quietly(sample_path("qif", "NIST_MTC_Incoming_PlateResults_20_samples.QIF", "full"))
    assert fair["part"].nunique() == 20 and incoming["part"].nunique() == 20
    # FAIR writes the 18.27 and 5.5 mm distances as absolute limits (18.77 / 17.77 …),
    # Incoming as ±0.5: both must come out as -0.5 / +0.5.
    for table in (fair, incoming):
        for nominal in (18.27, 5.5):
            rows = table[np.isclose(table["nominal"], nominal)]
            assert len(rows) == 20
            assert np.allclose(rows["lower"], -0.5) and np.allclose(rows["upper"], 0.5)


def _regenerate() -> None:  # pragma: no cover - maintenance entry point
    sys.path.insert(0, str(ROOT))
    for folder, shared, name, kind in PARSED:
        copy = COPIED / "qif" / name
        path = copy if copy.exists() else SHARED_SAMPLES / shared / name
        table = read_quietly(path)
        target = golden_file(folder, name, kind)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(render_full(table) if kind == "full" else render_summary(table), encoding="utf-8")
        print(f"{target.relative_to(ROOT)}: {len(table)} rows")


if __name__ == "__main__" and "--regenerate" in sys.argv:
    _regenerate()
