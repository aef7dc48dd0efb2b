"""Reader registry and dispatch; encodings and locale numbers of ``parsers.source``."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

import parsers
from parsers import registry as _registry
from parsers.source import decode, parse_number
from setupfix.core.errors import ParseError, UnknownFormatError

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"

MY_FORMATS = {"qif", "dmis", "calypso", "table", "canonical"}


def test_my_formats_are_registered_with_sniffers_and_readers() -> None:
    names = {s.name for s in parsers.formats()}
    assert names >= MY_FORMATS
    order = [s.name for s in parsers.formats()]
    # Specific formats are sniffed before the generic tables.
    assert order.index("qif") < order.index("canonical") < order.index("table")


@pytest.mark.parametrize(
    ("file", "expected"), [("cycle_01.csv", "canonical"), ("cycle_01.qif", "qif"), ("cycle_01.dmo", "dmis")]
)
def test_content_sniffing_picks_the_reader(file: str, expected: str) -> None:
    assert parsers.find_format(GUIDE / file).name == expected


def test_content_wins_over_extension(tmp_path: Path) -> None:
    disguised = tmp_path / "report.csv"
    disguised.write_bytes((GUIDE / "cycle_01.dmo").read_bytes())
    assert parsers.find_format(disguised).name == "dmis"


def test_extension_is_the_fallback(tmp_path: Path) -> None:
    odd = tmp_path / "odd.dmo"
    odd.write_text("garbage that no sniffer accepts\n", encoding="utf-8")
    assert parsers.find_format(odd).name == "dmis"
    with pytest.raises(ParseError, match=r"odd.dmo: no tolerance results"):
        parsers.read_report(odd).table


def test_explicit_format_wins_and_unknown_name_lists_the_known(tmp_path: Path) -> None:
    assert parsers.find_format(GUIDE / "cycle_01.csv", "table").name == "table"
    with pytest.raises(UnknownFormatError, match=r"unknown format 'qiff' \(known: .*qif"):
        parsers.find_format(GUIDE / "cycle_01.csv", "qiff")


def test_unaccepted_file_is_refused_with_formats_tried(tmp_path: Path) -> None:
    path = tmp_path / "notes.xyz"
    path.write_text("nothing measurable here\n", encoding="utf-8")
    with pytest.raises(UnknownFormatError) as info:
        parsers.read_report(path).table
    message = str(info.value)
    assert message.startswith(str(path)) and "tried:" in message
    assert all(name in message for name in MY_FORMATS)


def test_a_faulty_sniffer_does_not_stop_dispatch(monkeypatch: pytest.MonkeyPatch) -> None:
    def boom(peek: object) -> bool:
        raise RuntimeError("sniffer bug")

    spec = _registry.FormatSpec("zzboom", "test", (), boom, lambda path, **_: pd.DataFrame(), priority=1000)
    real = _registry.formats
    monkeypatch.setattr(_registry, "formats", lambda: [spec, *real()])
    assert parsers.find_format(GUIDE / "cycle_01.qif").name == "qif"


def test_missing_file_is_a_parse_error(tmp_path: Path) -> None:
    with pytest.raises(ParseError, match="cannot read"):
        parsers.read_report(tmp_path / "absent.qif").table


@pytest.mark.parametrize(
    ("data", "text"),
    [
        ("Lotlänge".encode(), "Lotlänge"),
        (b"\xef\xbb\xbf" + "Lotlänge".encode(), "Lotlänge"),
        ("Lotlänge".encode("cp1252"), "Lotlänge"),
        ("측정값 기준값".encode("cp949"), "측정값 기준값"),
        ("Ø 10".encode("utf-16"), "Ø 10"),
    ],
)
def test_encodings_are_sniffed(data: bytes, text: str) -> None:
    assert decode(data, "f") == text


def test_encoding_override_and_its_errors() -> None:
    assert decode("é".encode("latin-1"), "f", "latin-1") == "é"
    with pytest.raises(ParseError, match="unknown encoding 'klingon'"):
        decode(b"x", "f", "klingon")
    with pytest.raises(ParseError, match=r"f:2: bytes are not utf-8"):
        decode(b"ok\n\xff", "f", "utf-8")


@pytest.mark.parametrize(
    ("text", "value"), [("44,158745", 44.158745), ("-0,5", -0.5), ("1.5", 1.5), (" 2 ", 2.0), ("1e-3", 0.001)]
)
def test_parse_number_accepts_decimal_commas(text: str, value: float) -> None:
    assert parse_number(text) == value


@pytest.mark.parametrize("text", ["1,234,5", "inf", "nan", "", "1.2.3"])
def test_parse_number_refuses_non_numbers(text: str) -> None:
    with pytest.raises(ValueError):
        parse_number(text)


def test_canonical_csv_in_another_encoding_needs_and_accepts_encoding(tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    path.write_bytes("characteristic,nominal,actual\nMaß 1,1,1.01\n".encode("cp1252"))
    with pytest.raises(ParseError, match=r"c\.csv:2: not UTF-8 text \(give its encoding with --encoding\)"):
        parsers.read_report(path).table
    assert parsers.read_report(path, encoding="cp1252").table["characteristic"].iloc[0] == "Maß 1"
