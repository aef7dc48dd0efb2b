"""``batch --store`` marks what the history must leave out, per machine (issue 37, items 1 and 15).

A report with a gross value (rejected), one corrected with a draft model, one whose solve
stopped with nothing proven: each is stored for the record, marked, and left out of what the
history reads; the same report for a second machine is corrected and stored for that machine.
On SQLite and on the PostgreSQL test server alike (:mod:`pgserver`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import shutil
from pathlib import Path

import pytest
from conftest import GUIDE_PINS
from pgserver import location, pg_url

from setupfix.cli.batch import stored_line
from setupfix.model import load_model
from setupfix.store import excluded_reports, open_store, report_tables
from setupfix.usecases.batch import run_batch
from setupfix.usecases.batch_records import Claims, Outcome, Tally, exclusion
from setupfix.usecases.correct import correct_report
from setupfix.usecases.requests import CorrectRequest

__all__ = ["location", "pg_url"]

MODEL = GUIDE_PINS / "model.toml"


def sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


#: (characteristic, nominal, gross actual): the issue's P1 D1 at -0.5 mm, and P3 D4 0.55 mm over
GROSS = [("P1 D1", "25.0000", 24.5), ("P3 D4", "30.0000", 30.55)]


def folder_with_a_gross_value(tmp_path: Path, gross: tuple[str, str, float] = GROSS[1]) -> tuple[Path, Path]:
    """Cycles 1, 2, 4, 5 and a copy of cycle 3 with one gross value (a gross error): rejected."""
    d = tmp_path / "in"
    d.mkdir()
    for i in (1, 2, 4, 5):
        shutil.copy(GUIDE_PINS / f"cycle_0{i}.csv", d / f"cycle_0{i}.csv")
    path = d / "cycle_03.csv"
    name, nominal, actual = gross
    lines = (GUIDE_PINS / "cycle_03.csv").read_text().splitlines()
    i = next(k for k, line in enumerate(lines) if line.startswith(f"{name},{nominal},"))
    cells = lines[i].split(",")
    cells[2], cells[3] = f"{actual:.4f}", f"{actual - float(nominal):.4f}"
    lines[i] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    return d, path


@pytest.mark.parametrize("value", GROSS, ids=["P1 D1 -0.5", "P3 D4 +0.55"])
def test_a_rejected_report_is_stored_marked_and_left_out(
    tmp_path: Path, location: str, value: tuple[str, str, float]
) -> None:
    d, gross = folder_with_a_gross_value(tmp_path, value)
    name, _, actual = value
    model = load_model(MODEL)
    with open_store(location, machine="m1") as store:
        summary = run_batch(CorrectRequest(model), d, tmp_path / "o.csv", settle=0, store=store)
        assert summary.verdicts["reject"] == 1 and summary.reports == 5
        marks = {r.name: r.excluded for r in store.reports()}
        assert marks == {p.name: ("rejected" if p == gross else None) for p in d.iterdir()}
        assert [r.name for r in excluded_reports(store)] == [gross.name]
        # the history reads the clean four; the gross one only when asked for
        used = {rec.name for rec, _ in report_tables(store)}
        assert used == {p.name for p in d.iterdir()} - {gross.name}
        assert gross.name in {rec.name for rec, _ in report_tables(store, include_excluded=True)}
        rows = store.measurements()
        assert sha(gross) not in set(rows["report_sha256"])
        clean = rows.loc[rows["characteristic"] == name, "deviation"]
        assert len(clean) == 4 and clean.abs().max() < 0.1  # one value in each clean report
        kept = store.measurements(sha(gross))  # kept for the record
        assert actual in set(kept.loc[kept["characteristic"] == name, "actual"])
        verdicts = [r.result["verdict"] for r in store.recommendations()]
        assert verdicts.count("reject") == 1 and len(verdicts) == 5  # each report with its recommendation
    with open_store(location, machine="m1") as store:  # the mark is stored, not held in memory
        assert store.report(sha(gross)).excluded == "rejected"  # type: ignore[union-attr]


def test_a_draft_model_marks_every_report_draft(tmp_path: Path, location: str) -> None:
    d, _ = folder_with_a_gross_value(tmp_path)
    draft = dataclasses.replace(load_model(MODEL), draft=True)
    with open_store(location) as store:
        run_batch(CorrectRequest(draft), d, tmp_path / "o.csv", settle=0, store=store)
        assert {r.excluded for r in store.reports()} == {"draft"}
        assert report_tables(store) == []
        assert len(report_tables(store, include_excluded=True)) == 5
        # after the model's edit the same reports are corrected again (a draft's are never processed)
        # and the newest verdict sets the mark
        run_batch(CorrectRequest(load_model(MODEL)), d, tmp_path / "o2.csv", settle=0, store=store)
        assert sorted(str(r.excluded) for r in store.reports()) == ["None"] * 4 + ["rejected"]


def test_the_mark_follows_draft_then_reject_then_failure() -> None:
    assert exclusion(["apply", "reject"], [True, True], draft=True) == "draft"
    assert exclusion(["apply", "reject"], [True, True], draft=False) == "rejected"
    assert exclusion(["hold", "apply"], [False, True], draft=False) == "failed"
    assert exclusion(["apply", "hold"], [True, True], draft=False) is None


def test_a_report_processed_for_one_machine_is_corrected_and_stored_for_another(tmp_path: Path, location: str) -> None:
    d = tmp_path / "in"
    d.mkdir()
    for i in (2, 4):
        shutil.copy(GUIDE_PINS / f"cycle_0{i}.csv", d / f"cycle_0{i}.csv")
    model = load_model(MODEL)
    with open_store(location, machine="left") as store:
        first = run_batch(CorrectRequest(model), d, tmp_path / "a.csv", settle=0, store=store)
        assert first.reports == 2 and len(store.recommendations()) == 2
        again = run_batch(CorrectRequest(model), d, tmp_path / "b.csv", settle=0, store=store)
        assert again.reports == 0 and len(again.skipped) == 2  # processed for this machine
    with open_store(location, machine="right") as store:
        other = run_batch(CorrectRequest(model), d, tmp_path / "c.csv", settle=0, store=store)
        assert other.reports == 2 and not other.notes and not other.failed
        assert len(store.reports()) == 2 and len(store.recommendations()) == 2
        assert {r.machine for r in store.reports()} == {"right"}
    with open_store(location, machine="left") as store:  # --force stores what it corrects
        forced = run_batch(CorrectRequest(model), d, tmp_path / "d.csv", settle=0, store=store, force=True)
        assert forced.reports == 2 and not [n for _, n in forced.notes if n.kind == "store"]
        assert len(store.recommendations()) == 4 and len(store.reports()) == 2
        assert (tmp_path / "d.csv").read_text().count("\n") == (tmp_path / "a.csv").read_text().count("\n")


def corrected(path: Path, request: CorrectRequest) -> Outcome:
    """``path`` corrected as a batch worker does it, with the bytes and table the store records."""
    import parsers

    source = parsers.load_source(str(path))
    done = correct_report(request, source)
    return Outcome(
        str(path),
        sha256=hashlib.sha256(source.data).hexdigest(),
        verdicts=[c.verdict for c in done.cycles],
        parts=[c.part.part for c in done.cycles],
        solved=[c.solved for c in done.cycles],
        format=done.format,
        data=source.data,
        table=done.table,
    )


def test_the_summary_says_what_the_store_took_and_what_it_marked(tmp_path: Path) -> None:
    d, gross = folder_with_a_gross_value(tmp_path)
    request = CorrectRequest(load_model(MODEL))
    tally = Tally()
    assert tally.summary(1.0, True).stored is None and "stored" not in tally.summary(1.0, True).to_json()
    with open_store(tmp_path / "h.db") as store:
        claims = Claims(store, force=False)
        for path in (d / "cycle_01.csv", gross, d / "cycle_02.csv"):
            claims.record(corrected(path, request), request.solve)
        summary = tally.summary(1.0, True, claims)
        assert len(store.reports()) == 3 and len(store.recommendations()) == 3
    assert (summary.stored, dict(summary.excluded)) == (3, {"rejected": 1})
    assert summary.to_json()["stored"] == 3 and summary.to_json()["excluded"] == {"rejected": 1}
    assert stored_line(summary) == (
        "history store: 3 report(s) stored, each with its recommendations; 1 of them marked excluded "
        "(1 rejected): left out of the history, kept for the record"
    )
