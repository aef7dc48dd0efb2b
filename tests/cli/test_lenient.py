"""``--lenient`` on every command that reads a report: a self-contradicting row refuses the report
without it, and is skipped with a warning naming its line with it (the Korean layout is the reader
that can tell such a row apart)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import shared_path

from setupfix.cli import main

pytestmark = pytest.mark.needs_shared

SAMPLE = "KR_45926-4G100_230312_day_1-1-1_OK.cp949.txt"


@pytest.fixture(scope="module")
def setup(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    """(the sample, a copy whose line 32 contradicts itself, a scaffold of the sample's Y dimensions)."""
    sample = shared_path("cmm-samples", "korean_cmm_txt", SAMPLE)
    folder = tmp_path_factory.mktemp("lenient")
    lines = sample.read_bytes().decode("cp949").split("\n")
    # line 32: "Y  -10.905  10.900  0.100  -0.100  0.005": a deviation of 0.505 fits neither sign
    head, found, tail = lines[31].rpartition("0.005")
    assert found and lines[31].split()[0] == "Y"
    lines[31] = head + "0.505" + tail
    bad = folder / "reports" / "bad.txt"
    bad.parent.mkdir()
    bad.write_bytes("\n".join(lines).encode("cp949"))
    model = folder / "model.toml"
    assert main(["model", "init", str(sample), "-o", str(model), "--axis", "Y"]) == 0
    # the scaffold is a draft (correct holds with the rule "draft"): the rules below are those of the model checked
    model.write_text(model.read_text(encoding="utf-8").replace("\ndraft = true", "\ndraft = false"), encoding="utf-8")
    return sample, bad, model


def _refused(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    assert main(argv) != 0
    err = capsys.readouterr().err
    assert "bad.txt:32: stated deviation 0.505 mm fits neither" in err and "--lenient" in err


def test_correct_refuses_then_skips_the_row_with_a_warning(
    setup: tuple[Path, Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    _, bad, model = setup
    _refused(capsys, ["correct", "--model", str(model), "--json", str(bad)])
    assert main(["correct", "--model", str(model), "--json", "--lenient", str(bad)]) == 0
    out = json.loads(capsys.readouterr().out)
    # issue 22 (coverage): the skipped row's dimension is absent, so the registers that move it (in this scaffold
    # every feature is moved by W1; issue 23: no tool length along Y, the spindle being Z) are held at 0 and the
    # rule says so -- no longer an "apply"
    (coverage,) = [r for r in out["rules"] if r["rule"] == "coverage"]
    assert out["verdict"] == "hold" and set(coverage["registers"]) == {"W1"} and coverage["dimensions"]
    assert any(w.startswith(f"{bad}:32: ") and "contradicting themselves" in w for w in out["warnings"])
    # the skipped row is a model dimension: absent, listed, never guessed
    skipped = [d["id"] for d in out["dimensions"] if d["name"] == "점2.Y"]
    assert not skipped and out["absent"]


@pytest.mark.slow
def test_compare_check_init_and_batch_take_lenient_too(
    setup: tuple[Path, Path, Path], capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    _, bad, model = setup
    for argv, lenient_ok in (
        (["compare", "--model", str(model), "--trials", "1", "--json", str(bad)], "warnings"),
        (["model", "check", str(model), "--json", str(bad)], "notes"),
        (["model", "init", str(bad), "-o", str(tmp_path / "m.toml")], None),
        (["diagnose", "--model", str(model), "--no-walk", "--json", str(bad)], "diagnose"),
    ):
        _refused(capsys, argv)
        assert main([*argv, "--lenient"]) == 0
        captured = capsys.readouterr()
        if lenient_ok == "warnings":
            warnings = json.loads(captured.out)["warnings"]
        elif lenient_ok == "diagnose":
            warnings = json.loads(captured.out)["notes"]
        elif lenient_ok == "notes":
            warnings = [f"{n['location']}: {n['message']}" for n in json.loads(captured.out)["parts"][0]["notes"]]
        else:
            warnings = captured.err.splitlines()
        assert any(":32: " in w and "contradicting themselves" in w for w in warnings), (argv[0], warnings)
    out = tmp_path / "offsets.csv"
    batch = ["batch", str(bad.parent), "--model", str(model), "--out", str(out), "--settle", "0", "--json"]
    assert main(batch) != 0
    assert json.loads(capsys.readouterr().out)["failed"][0]["reason"].startswith(f"{bad}:32: ")
    assert main([*batch, "--lenient"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["reports"] == 1 and not summary["failed"] and out.exists()
    assert any(":32: " in n["note"] and "contradicting themselves" in n["note"] for n in summary["notes"])


def test_lenient_is_harmless_where_the_reader_never_skips_a_row(capsys: pytest.CaptureFixture[str]) -> None:
    """A folder of mixed formats can be read with --lenient: readers without such rows ignore it."""
    csv = Path(__file__).resolve().parents[2] / "sample_reports" / "guide_pins" / "cycle_01.csv"
    assert main(["parse", "--lenient", str(csv), "--out", "-"]) == 0
    lenient = capsys.readouterr().out
    assert main(["parse", str(csv), "--out", "-"]) == 0
    assert lenient == capsys.readouterr().out and lenient.count("\n") > 20


def test_history_import_takes_lenient(
    setup: tuple[Path, Path, Path], capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    _, bad, _ = setup
    db = tmp_path / "h.db"
    _refused(capsys, ["history", "import", "--db", str(db), str(bad)])
    assert main(["history", "import", "--db", str(db), "--lenient", str(bad)]) == 0
    captured = capsys.readouterr()
    assert "1 new report(s)" in captured.out and f"{bad}:32: " in captured.err
