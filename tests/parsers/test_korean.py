"""Korean CMM text reader on the CP949 samples (no licence: used from ../shared, not copied).

Goldens hold derived numbers only (line, part number, values, limits, status).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import parsers
from parsers.korean import read_korean
from setupfix.errors import ParseError, ParseWarning

SHARED = Path(__file__).resolve().parents[3] / "shared" / "cmm-samples" / "korean_cmm_txt"
GOLDEN = Path(__file__).resolve().parent / "golden"
DERIVED = ["line", "part_no", "nominal", "actual", "deviation", "lower", "upper", "status"]
NAMES = sorted(p.name for p in SHARED.glob("KR_*.txt")) or ["KR_45926-4G100_240113_night_2-2-1_NG.cp949.txt"]


def shared(name: str) -> Path:
    path = SHARED / name
    if not path.exists():
        pytest.skip(f"../shared is not beside the project ({path} absent): unlicensed sample not redistributed")
    return path


def read_warned(read, path: Path) -> tuple[pd.DataFrame, str]:
    """Read ``path``, returning the table and all ParseWarning messages joined."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ParseWarning)
        table = read(path)
    return table, "\n".join(str(w.message) for w in caught if issubclass(w.category, ParseWarning))


def derived(table: pd.DataFrame) -> pd.DataFrame:
    """The numbers of a canonical table, without text taken from the report."""
    out = pd.DataFrame({
        "line": table["source"].str.rsplit(":", n=1).str[-1].astype(int),
        "part_no": pd.factorize(table["part"])[0] + 1,
    })
    for col in DERIVED[2:]:
        out[col] = table[col]
    return out


@pytest.mark.parametrize("name", NAMES)
def test_sample_matches_derived_golden(name: str) -> None:
    path = shared(name)
    assert parsers.find_format(path).name == "korean"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ParseWarning)
        table = parsers.read(path)
    got = derived(table)
    want = pd.read_csv(GOLDEN / f"korean_{name.split('.')[0]}.csv", keep_default_na=False, na_values=[""], dtype={"status": str})
    assert got["line"].tolist() == want["line"].tolist()
    assert got["part_no"].tolist() == want["part_no"].tolist()
    assert got["status"].fillna("").tolist() == want["status"].fillna("").tolist()
    for col in ("nominal", "actual", "deviation", "lower", "upper"):
        np.testing.assert_allclose(got[col].to_numpy(float), want[col].to_numpy(float), atol=1e-9, equal_nan=True)


def test_ng_report_out_of_tolerance_and_sign_quirk() -> None:
    table, messages = read_warned(read_korean, shared("KR_45926-4G100_240113_night_2-2-1_NG.cp949.txt"))
    assert "differ in sign (magnitudes compared): line 32" in messages
    row = table[table["source"].str.endswith(":31")].iloc[0]  # X 116.728, nominal 116.600, +0.100/0.000, excess 0.028
    assert (row["deviation"], row["lower"], row["upper"], row["status"]) == (pytest.approx(0.128), 0.0, 0.1, "out")
    assert table["timestamp"].iloc[0] == "2024-01-13T22:55:39"
    assert not table["source"].str.endswith(":32").any()


def test_second_part_suffix_gives_second_part() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ParseWarning)
        table = read_korean(shared("KR_45926-4G100_240321_day_1-2-1_OK.cp949.txt"))
    parts = table["part"].unique().tolist()
    assert len(parts) == 2 and parts[1] == parts[0] + "#2"
    first, second = (set(table.loc[table["part"] == p, "characteristic"]) for p in parts)
    assert len(first & second) >= 20  # "원1#2(I)" is named like "원1(I)" so both match one dimension


def test_encoding_sniffed_and_override(tmp_path: Path) -> None:
    path = shared("KR_45926-4G400_230312_day_1-1-1_NG.cp949.txt")
    utf8 = tmp_path / "utf8.txt"
    utf8.write_text(path.read_bytes().decode("cp949"), encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ParseWarning)
        a, b = read_korean(path), read_korean(utf8, encoding="utf-8")
    pd.testing.assert_frame_equal(a.drop(columns=["source", "report"]), b.drop(columns=["source", "report"]))
    with pytest.raises(ParseError, match="bytes are not utf-8 text"):
        read_korean(path, encoding="utf-8")


def test_misplaced_value_names_the_line(tmp_path: Path) -> None:
    lines = shared("KR_45926-4G100_240113_night_2-2-1_NG.cp949.txt").read_bytes().decode("cp949").split("\n")
    lines[12] = lines[12].replace("16.497", "16,4x7")
    path = tmp_path / "bad.txt"
    path.write_bytes("\n".join(lines).encode("cp949"))
    with pytest.raises(ParseError, match=r"bad\.txt:13: 측정값: expected a number"):
        read_korean(path)
