"""Mitutoyo QVPAK reader: the two public samples (GPL-3.0, from ../shared) are refused with
their reason (actual values only, or angles only); the nominal path is checked on a report
written here in the same layout."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import SHARED as SHARED_ROOT
from goldens import expect_note

import parsers
from parsers.mitutoyo import read_qvpak
from setupfix.core.errors import ParseError

SHARED = SHARED_ROOT / "cmm-samples" / "mitutoyo"

HEADING = (
    "        Elemento           Atual         Nominal          Desvio        Tol.sup.        Tol.inf.        De./Fora"
)


def shared(name: str) -> Path:
    path = SHARED / name
    if not path.exists():
        pytest.skip(f"../shared is not beside the project ({path} absent): GPL sample not redistributed")
    return path


def test_distances_sample_is_refused_because_it_holds_actuals_only() -> None:
    path = shared("Mitutoyo_QVPAK_sample1_distances.txt")
    assert parsers.find_format(path).name == "qvpak"
    with pytest.raises(ParseError, match=r"120 row\(s\) with an actual value only \(no nominal\) \(line 5, 8, 11"):
        parsers.read_report(path).table


def test_angles_sample_is_refused_because_angles_are_not_lengths() -> None:
    with pytest.raises(ParseError, match=r"60 angle row\(s\)"):
        read_qvpak(shared("Mitutoyo_QVPAK_sample2_angles.txt"))


def _report(tmp_path: Path, *values: str) -> Path:
    lines = ["", HEADING, "Distância: Dist-1(ID:3) entre Ponto-1(ID:1) e Ponto-2(ID:2)"]
    lines += [f"           {v}" for v in values]
    path = tmp_path / "qv.txt"
    path.write_bytes("\r\n".join([*lines, ""]).encode("cp1252"))
    return path


def test_nominal_columns_decimal_comma_and_verdict(tmp_path: Path) -> None:
    line = "DX =        44,158745       44,150000        0,008745        0,010000       -0,010000              De"
    path = _report(tmp_path, line, "CA =           95,554          95,500")
    with expect_note():
        table = read_qvpak(path)
    row = table.iloc[0]
    assert row["characteristic"] == "Dist-1.DX" and row["source"].endswith("qv.txt:4")
    assert (row["actual"], row["nominal"], row["lower"], row["upper"]) == pytest.approx((44.158745, 44.15, -0.01, 0.01))
    assert row["status"] == "ok" and len(table) == 1


def test_inch_option_and_contradiction(tmp_path: Path) -> None:
    line = "DX =         1,000000        0,990000        0,010000"
    assert read_qvpak(_report(tmp_path, line), unit="inch")["actual"].iloc[0] == pytest.approx(25.4)
    bad = "DX =         1,000000        0,990000        0,020000"
    with pytest.raises(ParseError, match=r"qv\.txt:4: stated deviation"):
        read_qvpak(_report(tmp_path, bad))
