"""A QVPAK report of actual values only is refused for that cause (issue 37 item 17), even where it holds
quantities this reader does not know (``Raio`` of a circle, as the upstream repository's sample3.txt,
or any other): an actual alone is unusable whatever it measures."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import SHARED as SHARED_ROOT
from goldens import expect_note

import parsers
from parsers.mitutoyo import read_qvpak
from setupfix.core.errors import ParseError

SHARED = SHARED_ROOT / "cmm-samples" / "mitutoyo" / "Mitutoyo_QVPAK_sample1_distances.txt"
CIRCLE = "Círculo: Círculo-3-1-1(ID:21, De 6 Pts.) \r\n         {label} =        14,388559{tail}\r\n\r\n"


def with_circles(tmp_path: Path, label: str, tail: str = "") -> Path:
    """The shared sample with circle elements inserted after its heading (as sample3.txt has them)."""
    if not SHARED.exists():
        pytest.skip(f"{SHARED} absent: GPL sample not redistributed")
    text = SHARED.read_bytes().decode("cp1252")
    heading_end = text.index("\n", text.index("Elemento")) + 1
    extra = "".join(CIRCLE.format(label=label, tail=tail) for _ in range(3))
    path = tmp_path / "qvpak_circles.txt"
    path.write_bytes((text[:heading_end] + extra + text[heading_end:]).encode("cp1252"))
    return path


@pytest.mark.parametrize("label", ["Raio", "RAIO", "Circ", "Forma"])
def test_actuals_only_are_refused_for_their_missing_nominals(tmp_path: Path, label: str) -> None:
    path = with_circles(tmp_path, label)
    assert parsers.find_format(path).name == "qvpak"
    with pytest.raises(ParseError) as info:
        parsers.read_report(path).table
    message = str(info.value)
    assert "unknown quantity" not in message
    assert "123 row(s) with an actual value only (no nominal)" in message


def test_a_radius_with_its_nominal_is_read(tmp_path: Path) -> None:
    heading = "        Elemento           Atual         Nominal          Desvio        Tol.sup.        Tol.inf."
    row = "         Raio =        14,388559       14,400000       -0,011441        0,020000       -0,020000"
    path = tmp_path / "qv.txt"
    path.write_bytes(f"\r\n{heading}\r\nCírculo: Círculo-1(ID:21, De 6 Pts.)\r\n{row}\r\n".encode("cp1252"))
    with expect_note():
        table = read_qvpak(path)
    assert table["characteristic"].tolist() == ["Círculo-1.RAIO"]
    assert table["deviation"].iloc[0] == pytest.approx(-0.011441)


def test_an_unknown_quantity_with_a_nominal_is_still_refused(tmp_path: Path) -> None:
    heading = "        Elemento           Atual         Nominal          Desvio"
    row = "         Forma =        0,012000        0,000000        0,012000"
    path = tmp_path / "qv.txt"
    path.write_bytes(f"\r\n{heading}\r\nCírculo: Círculo-1(ID:21, De 6 Pts.)\r\n{row}\r\n".encode("cp1252"))
    with pytest.raises(ParseError, match=r"qv\.txt:4: unknown quantity 'FORMA'"):
        read_qvpak(path)
