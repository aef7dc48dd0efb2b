"""Issue 21 item 7: a part stored twice (a CRLF copy, an export imported again) counts once in the EWMA.

Identity is the part -- name, time, deviations -- not the bytes of the file that brought it
(:func:`setupfix.inputs.smoothing.part_identity`, applied on read by ``History``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, cast

import pytest

from setupfix.cli import main

GUIDE = Path(__file__).resolve().parents[2] / "sample_reports" / "guide_pins"


def _model(tmp_path: Path) -> Path:
    path = tmp_path / "m.toml"
    path.write_text((GUIDE / "model.toml").read_text() + "\n[safety]\newma = 0.5\n")
    return path


def _unnamed(tmp_path: Path, i: int) -> Path:
    """cycle_0i without its part column: the part is named by nothing but its report and time."""
    lines = (GUIDE / f"cycle_0{i}.csv").read_text().splitlines()
    head = lines[0].split(",")
    k = head.index("part")
    path = tmp_path / f"unnamed_0{i}.csv"
    path.write_text("\n".join(",".join(c for j, c in enumerate(line.split(",")) if j != k) for line in lines) + "\n")
    return path


def _estimates(tmp_path: Path, model: Path, db: Path, capsys: pytest.CaptureFixture[str]) -> dict[str, Any]:
    capsys.readouterr()
    assert main(["correct", "--model", str(model), "--store", str(db), str(GUIDE / "cycle_03.csv"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    (part,) = out.get("parts", [out])
    return cast(dict[str, Any], part)


def _ewma(part: dict[str, Any]) -> tuple[list[float], list[dict[str, Any]]]:
    rows = part["dimensions"]
    return [r["estimate"] for r in rows], [r for r in part["rules"] if r["rule"] == "ewma"]


@pytest.mark.slow
@pytest.mark.parametrize("named", [True, False])
def test_crlf_copy_and_export_import_do_not_change_the_ewma(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], named: bool
) -> None:
    model = _model(tmp_path)
    reports = (
        [GUIDE / "cycle_01.csv", GUIDE / "cycle_02.csv"] if named else [_unnamed(tmp_path, 1), _unnamed(tmp_path, 2)]
    )
    base = tmp_path / "base.db"
    assert main(["history", "import", "--db", str(base), *map(str, reports)]) == 0
    want = _estimates(tmp_path, model, base, capsys)
    # a CRLF copy of the first report beside the stored one
    crlf = tmp_path / "copy_crlf.csv"
    crlf.write_bytes(reports[0].read_bytes().replace(b"\n", b"\r\n"))
    copy_db = tmp_path / "crlf.db"
    copy_db.write_bytes(base.read_bytes())
    assert main(["history", "import", "--db", str(copy_db), str(crlf)]) == 0
    # the store's measurements exported and imported again (one file holding both reports)
    exported = tmp_path / "export.csv"
    assert main(["history", "export", "measurements", "--db", str(base), "--out", str(exported)]) == 0
    round_db = tmp_path / "round.db"
    round_db.write_bytes(base.read_bytes())
    assert main(["history", "import", "--db", str(round_db), str(exported)]) == 0
    for db in (copy_db, round_db):
        got = _estimates(tmp_path, model, db, capsys)
        assert got["dimensions"] == want["dimensions"], db.name
        assert [r for r in got.get("rules", []) if "earlier part" in str(r)] == [
            r for r in want.get("rules", []) if "earlier part" in str(r)
        ], db.name


def test_two_unnamed_parts_of_one_time_that_measured_differently_both_count(tmp_path: Path) -> None:
    """Within a report's time resolution two unnamed parts are told apart by their values (the former
    (name, time) key kept only one)."""
    import parsers
    from setupfix.model import load_model, match_parts
    from setupfix.usecases.requests import History

    model = load_model(_model(tmp_path))
    a = _unnamed(tmp_path, 1)
    b = tmp_path / "b.csv"
    lines = a.read_text().splitlines()
    head = lines[0].split(",")
    act, dev, stamp = head.index("actual"), head.index("deviation"), head.index("timestamp")
    stamp_a = lines[1].split(",")[stamp]
    out = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        cells[act], cells[dev] = f"{float(cells[act]) + 0.001:.4f}", f"{float(cells[dev]) + 0.001:.4f}"
        cells[stamp] = stamp_a
        out.append(",".join(cells))
    b.write_text("\n".join(out) + "\n")
    parts = [p for f in (a, b) for p in match_parts(model, parsers.read(f), source=f.name)]
    assert len(History.empty(model).with_parts(parts).keys) == 2
    assert len(History.empty(model).with_parts(parts + parts).keys) == 2
