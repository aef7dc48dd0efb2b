"""Issue 37 item 1 in batch's smoothing: a report the batch rejects does not enter the EWMA of the others.

With the model's EWMA a batch smooths each report over the store and every report of the batch
machined before it.  A report with a gross value (here P2 D4 0.45 mm over in cycle 03, a variant of the
issue's P1 D1 at −0.5 mm) is rejected and stored marked; the reports after it must be corrected as if
it were not there, as ``correct --store`` after the batch would correct them.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from conftest import GUIDE_PINS

from setupfix.model import load_model
from setupfix.store import open_store
from setupfix.usecases.batch import rejected, run_batch
from setupfix.usecases.requests import CorrectRequest

ROW = "P2 D4,30.0000,30.0112,0.0112"


def ewma_model(tmp_path: Path) -> Path:
    path = tmp_path / "m.toml"
    path.write_text((GUIDE_PINS / "model.toml").read_text() + "\n[safety]\newma = 0.5\n")
    return path


def rows_by_report(out: Path) -> dict[str, list[str]]:
    rows: dict[str, list[str]] = {}
    for line in out.read_text().splitlines()[1:]:
        cells = line.split(",")
        rows.setdefault(cells[0], []).append(",".join(cells[1:]))
    return rows


def test_a_rejected_report_of_the_batch_is_left_out_of_the_others_smoothing(tmp_path: Path) -> None:
    model = load_model(ewma_model(tmp_path))
    clean, dirty = tmp_path / "clean", tmp_path / "dirty"
    for d in (clean, dirty):
        d.mkdir()
        for i in (1, 2, 4, 5):
            shutil.copy(GUIDE_PINS / f"cycle_0{i}.csv", d / f"cycle_0{i}.csv")
    text = (GUIDE_PINS / "cycle_03.csv").read_text()
    assert ROW in text
    (dirty / "cycle_03.csv").write_text(text.replace(ROW, "P2 D4,30.0000,30.4586,0.4586"))
    got: dict[str, dict[str, list[str]]] = {}
    for d in (clean, dirty):
        with open_store(tmp_path / f"{d.name}.db") as store:
            summary = run_batch(CorrectRequest(model), d, tmp_path / f"{d.name}.csv", settle=0, store=store)
            assert summary.verdicts["reject"] == (d == dirty)
        got[d.name] = rows_by_report(tmp_path / f"{d.name}.csv")
    assert set(got["dirty"]) == {"cycle_01.csv", "cycle_02.csv", "cycle_03.csv", "cycle_04.csv", "cycle_05.csv"}
    for name in ("cycle_04.csv", "cycle_05.csv"):  # smoothed over cycle 03 before: other corrections
        assert got["dirty"][name] == got["clean"][name]
    # again, forced: the store now holds cycle 03 marked; the run says once that it left it out
    with open_store(tmp_path / "dirty.db") as store:
        again = run_batch(CorrectRequest(model), dirty, tmp_path / "again.csv", settle=0, store=store, force=True)
    said = [str(n) for _, n in again.notes if n.kind == "excluded"]
    assert said == [
        "1 stored report(s) marked rejected, failed or draft left out of the smoothing history "
        "(--include-excluded takes them in)"
    ]
    assert rows_by_report(tmp_path / "again.csv")["cycle_05.csv"] == got["clean"]["cycle_05.csv"]
    # asked to, the batch takes the marked report in, stored and of the run alike: cycle 05 moves
    with open_store(tmp_path / "dirty.db") as store:
        request = CorrectRequest(model)
        taken = run_batch(
            request, dirty, tmp_path / "taken.csv", settle=0, store=store, force=True, include_excluded=True
        )
    assert not [n for _, n in taken.notes if n.kind == "excluded"]
    assert rows_by_report(tmp_path / "taken.csv")["cycle_05.csv"] != got["clean"]["cycle_05.csv"]


def test_rejected_is_the_reject_rule_on_the_part_as_measured(tmp_path: Path) -> None:
    import parsers
    from setupfix.model import match_parts

    model = load_model(GUIDE_PINS / "model.toml")
    text = (GUIDE_PINS / "cycle_03.csv").read_text()
    assert ROW in text
    for gross, want in (("0.0112", False), ("0.4586", True), ("0.1300", False)):  # 0.13: out, within the band
        path = tmp_path / f"{gross}.csv"
        path.write_text(text.replace(ROW, f"P2 D4,30.0000,{30 + float(gross):.4f},{gross}"))
        (part,) = match_parts(model, parsers.read(path))
        assert rejected(model, part) is want, gross
