"""Every door records and reads as one machine: --machine / --operator / [process] machine on correct, batch,
diagnose and spc, on both back ends (issue 25: machine identity and the audit trail)."""

from __future__ import annotations

import csv
import hashlib
import io
import json
from pathlib import Path

import pytest
from store.test_plant import GUIDE, MODEL, machine_reports

from setupfix.cli import main
from setupfix.model import load_model
from setupfix.store import open_store


def audit(capsys: pytest.CaptureFixture[str], db: str, *extra: str) -> list[dict[str, str]]:
    capsys.readouterr()
    assert main(["history", "export", "recommendations", "--db", db, "--out", "-", *extra]) == 0
    return list(csv.DictReader(io.StringIO(capsys.readouterr().out)))


def created(location: str) -> str:
    """The store at ``location``, created empty (``correct --store`` opens an existing store only)."""
    with open_store(location):
        pass
    return location


def test_correct_records_its_recommendation_and_the_program_it_wrote(
    tmp_path: Path, location: str, capsys: pytest.CaptureFixture[str]
) -> None:
    db = created(location)
    report = GUIDE / "cycle_01.csv"
    program = tmp_path / "o.nc"
    assert (
        main(
            [
                "correct",
                "--model",
                str(MODEL),
                str(report),
                "--store",
                db,
                "--machine",
                "M1",
                "--operator",
                "alice",
                "--offsets",
                str(program),
                "--controller",
                "fanuc",
            ]
        )
        == 0
    )
    rows = audit(capsys, db, "--machine", "M1")
    registers = {r.id for r in load_model(MODEL).registers}
    assert {r["register"] for r in rows} == registers  # one row per register component, zero included
    sha = hashlib.sha256(report.read_bytes()).hexdigest()
    assert {(r["machine"], r["operator"], r["report_sha256"], r["verdict"]) for r in rows} == {
        ("M1", "alice", sha, "apply")
    }
    assert {r["exported_to"] for r in rows} == {str(program)}
    assert len({r["applied"] for r in rows}) == 1 and rows[0]["applied"] in ("0", "false", "False")
    text = program.read_text(encoding="utf-8")
    deltas = {r["register"]: float(r["delta"]) for r in rows}
    assert any(abs(d) > 0 for d in deltas.values()) and "G10" in text
    assert audit(capsys, db, "--machine", "M2") == []  # another machine's handle sees none of it


def test_the_models_machine_is_the_default(tmp_path: Path, location: str, capsys: pytest.CaptureFixture[str]) -> None:
    created(location)
    model = tmp_path / "m.toml"
    text = MODEL.read_text(encoding="utf-8")
    model.write_text(text.replace("[process]\n", '[process]\nmachine = "VMC-7"\n', 1), encoding="utf-8")
    assert main(["correct", "--model", str(model), str(GUIDE / "cycle_02.csv"), "--store", location]) == 0
    assert {r["machine"] for r in audit(capsys, location)} == {"VMC-7"}
    assert (
        main(["correct", "--model", str(model), str(GUIDE / "cycle_03.csv"), "--store", location, "--machine", "VMC-8"])
        == 0
    )  # --machine overrides the model's
    assert {r["machine"] for r in audit(capsys, location)} == {"VMC-7", "VMC-8"}


@pytest.mark.slow
def test_batch_and_diagnose_see_only_their_machine(
    tmp_path: Path, location: str, capsys: pytest.CaptureFixture[str]
) -> None:
    for machine in ("A", "B"):
        folder = tmp_path / machine
        machine_reports(folder, machine, 6 if machine == "A" else 4)
        assert (
            main(
                [
                    "batch",
                    str(folder),
                    "--model",
                    str(MODEL),
                    "--out",
                    str(tmp_path / f"{machine}.csv"),
                    "--store",
                    location,
                    "--machine",
                    machine,
                    "--settle",
                    "0",
                ]
            )
            == 0
        )
    with open_store(location) as store:
        summary = {m.machine: m.reports for m in store.machines()}
    assert summary == {"A": 6, "B": 4}
    for machine, cycles in (("A", 6), ("B", 4)):
        capsys.readouterr()
        assert (
            main(["diagnose", "--model", str(MODEL), "--db", location, "--machine", machine, "--json", "--no-walk"])
            == 0
        )
        assert json.loads(capsys.readouterr().out)["cycles"] == cycles
    capsys.readouterr()
    assert main(["diagnose", "--model", str(MODEL), "--db", location, "--machine", "C", "--no-walk"]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err


def test_a_url_for_a_missing_file_store_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "none.db"
    assert main(["correct", "--model", str(MODEL), str(GUIDE / "cycle_01.csv"), "--store", str(missing)]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(missing) in err and not missing.exists()
    assert not Path(missing).exists()
