"""Issue 37 item 13 in ``spc``: copies of a part stored under other bytes do not raise n nor Cp.

The issue: five case-variant copies raised n from 25 to 30 and Cp from 1.49 to 1.80.  Variant here:
20 parts of three characteristics in four reports, then five copies of parts -- the part name in other
case or spacing, CRLF line ends, values written at 6 decimals, one copy lacking a row -- stored as
reports of their own.  n, Cp and Cpk stay what the clean store gives; a part measured one step of
the report's resolution apart is another part and counts.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from setupfix.store import open_store
from setupfix.usecases.history import ImportRequest, import_history
from setupfix.usecases.spc_report import SpcOutcome, SpcRequest, spc_report

HEAD = "characteristic,nominal,actual,lower,upper,part,timestamp"


def value(i: int, c: int) -> float:
    """A deterministic spread of deviations (4 decimals) for part ``i``, characteristic ``c``."""
    return round(0.004 * float(np.sin(1.7 * i + c)) + 0.001 * ((3 * i + c) % 5), 4)


def rows(i: int, *, name: str | None = None, decimals: int = 4, drop: str = "", shift: float = 0.0) -> list[str]:
    stamp = f"2026-03-01T{8 + i // 4:02d}:{(i % 4) * 15:02d}:00"
    out = []
    for c, ch in enumerate(("D1", "D2", "D3")):
        if ch == drop:
            continue
        actual = 5 + value(i, c) + (shift if c == 0 else 0.0)
        out.append(f"{ch},5,{actual:.{decimals}f},-0.01,0.01,{name or f'part {i:02d}'},{stamp}")
    return out


def write(path: Path, lines: list[str], crlf: bool = False) -> Path:
    path.write_bytes(("\r\n" if crlf else "\n").join([HEAD, *lines]).encode() + b"\n")
    return path


def outcome(db: Path, reports: list[Path]) -> SpcOutcome:
    with open_store(db) as store:
        import_history(store, ImportRequest(reports=tuple(reports)))
        return spc_report(store, SpcRequest())


def test_case_variant_copies_of_parts_count_once(tmp_path: Path) -> None:
    clean = [write(tmp_path / f"r{k}.csv", [r for i in range(5 * k, 5 * k + 5) for r in rows(i)]) for k in range(4)]
    copies = [
        write(tmp_path / "c1.csv", rows(3, name="PART 03")),
        write(tmp_path / "c2.csv", rows(7, name="part  07 "), crlf=True),
        write(tmp_path / "c3.csv", rows(11, name="Part 11", decimals=6)),
        write(tmp_path / "c4.csv", rows(12, name="PART 12", drop="D2")),
        write(tmp_path / "c5.csv", rows(19, name="pArT 19", decimals=5), crlf=True),
    ]
    want = outcome(tmp_path / "clean.db", clean)
    got = outcome(tmp_path / "copies.db", clean + copies)
    for w, g in zip(want.dimensions, got.dimensions, strict=True):
        assert (g.name, g.capability.n) == (w.name, w.capability.n) == (w.name, 20)
        assert g.capability.cp == w.capability.cp and g.capability.cpk == w.capability.cpk
        np.testing.assert_array_equal(g.values, w.values)
    assert "14 value(s) of parts stored more than once: counted once" in [n.message for n in got.notes]
    # one step of the report's resolution (0.0001) on one value: another part, counted
    moved = write(tmp_path / "m.csv", rows(3, name="PART 03", shift=0.0001))
    more = outcome(tmp_path / "moved.db", [*clean, moved])
    assert [d.capability.n for d in more.dimensions] == [21, 21, 21]
