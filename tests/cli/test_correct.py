"""`setupfix correct` and `setupfix model show` end to end on the bundled sample."""

from __future__ import annotations

import csv
import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from conftest import GUIDE_PINS

from setupfix.cli import main

MODEL = str(GUIDE_PINS / "model.toml")
REPORT = str(GUIDE_PINS / "cycle_01.csv")
SPEC_KEYS = {"optimizer", "margin_before", "margin_after", "bonus", "norm", "corrections", "binding", "dimensions"}


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_json_has_the_contract_keys(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "correct", "--model", MODEL, "--json", REPORT)
    assert code == 0, err
    doc = json.loads(out)
    assert doc.keys() >= SPEC_KEYS
    assert doc["optimizer"] == "exact"
    assert set(doc["corrections"]) == {f"W{i}" for i in range(1, 9)} | {"T5", "T23"}
    assert doc["bonus"] == pytest.approx(doc["margin_after"] - doc["margin_before"])
    assert doc["margin_after"] > doc["margin_before"]
    dim = doc["dimensions"][0]
    assert {"id", "name", "deviation", "predicted", "lower", "upper"} <= dim.keys()
    assert dim["name"] == "P1 D1" and dim["deviation"] == pytest.approx(-0.0309)
    assert all(name.startswith("P") for name in doc["binding"])
    # predicted = deviation + x·C recomputed by hand for D4 = F4 - F3 (W1 + W5 + 2·T23)
    c = doc["corrections"]
    d4 = next(d for d in doc["dimensions"] if d["id"] == "P1D4")
    assert d4["predicted"] == pytest.approx(d4["deviation"] + c["W1"] + c["W5"] + 2 * c["T23"])


def test_offsets_csv_matches_json(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    target = tmp_path / "offsets.csv"
    code, out, _ = run(capsys, "correct", "--model", MODEL, "--json", "--offsets", str(target), REPORT)
    assert code == 0
    with target.open(encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    # the spec's columns first, in its order; then offset, current, value, verdict
    assert list(rows[0])[:9] == ["report", "part", "id", "register", "kind", "axis", "delta", "unit", "mode"]
    assert {r["unit"] for r in rows} == {"mm"} and {r["mode"] for r in rows} == {"add"}
    corrections = json.loads(out)["corrections"]
    assert {r["id"]: float(r["delta"]) for r in rows} == pytest.approx(corrections)
    by_id = {r["id"]: r for r in rows}
    assert by_id["W5"]["register"] == "G58" and by_id["W5"]["kind"] == "wks"
    assert by_id["T23"]["register"] == "H23" and by_id["T23"]["kind"] == "tool" and by_id["T23"]["axis"] == "Z"
    assert [p.name for p in tmp_path.iterdir()] == ["offsets.csv"]  # no temporary file left behind


def test_human_output_names_everything(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "correct", "--model", MODEL, REPORT)
    assert code == 0
    for text in ("P4 D7", "G54.1P2", "H23", "error budget before", "bonus", "binding"):
        assert text in out


def test_cripso_reproducible_per_seed(capsys: pytest.CaptureFixture[str]) -> None:
    outs = [
        json.loads(
            run(capsys, "correct", "--model", MODEL, "--optimizer", "cripso", "--seed", "4", "--json", REPORT)[1]
        )
        for _ in range(2)
    ]
    assert outs[0]["corrections"] == outs[1]["corrections"]
    assert outs[0]["optimizer"] == "cripso"


def test_several_parts_and_part_selection(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    both = tmp_path / "two.csv"
    lines = (GUIDE_PINS / "cycle_01.csv").read_text().splitlines()
    lines2 = (GUIDE_PINS / "cycle_02.csv").read_text().splitlines()[1:]
    both.write_text("\n".join(lines + lines2) + "\n")
    code, out, _ = run(capsys, "correct", "--model", MODEL, "--json", str(both))
    assert code == 0
    assert [p["part"] for p in json.loads(out)["parts"]] == ["cycle 01", "cycle 02"]
    code, out, _ = run(capsys, "correct", "--model", MODEL, "--json", "--part", "cycle 02", str(both))
    assert json.loads(out)["part"] == "cycle 02"
    code, _, err = run(capsys, "correct", "--model", MODEL, "--part", "cycle 9", str(both))
    assert code == 1 and "no part 'cycle 9'" in err


def test_absent_dimension_left_out_and_reported(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    report = tmp_path / "short.csv"
    lines = REPORT and (GUIDE_PINS / "cycle_01.csv").read_text().splitlines()
    report.write_text("\n".join(line for line in lines if not line.startswith("P3 D4")) + "\n")
    code, out, _ = run(capsys, "correct", "--model", MODEL, "--json", str(report))
    doc = json.loads(out)
    assert code == 0 and doc["absent"] == ["P3D4"]
    assert "P3D4" not in {d["id"] for d in doc["dimensions"]}


@pytest.mark.parametrize(
    ("mutate", "expected"),
    [
        (lambda d: (d / "model.toml").write_text("[process\n"), "model.toml:1: TOML syntax"),
        (lambda d: (d / "model.toml").unlink(), "cannot read model"),
        (
            lambda d: (d / "r.csv").write_text("characteristic,nominal,actual\nP1 D1,25,abc\n"),
            "r.csv:2: column 'actual': expected a number, found 'abc'",
        ),
        (
            lambda d: (d / "r.csv").write_text("characteristic,nominal,actual\nBore 9,25,25.1\n"),
            "no characteristic of part",
        ),
        (lambda d: (d / "r.csv").write_bytes(b"\x00\x01binary\xff"), "r.csv"),
    ],
)
def test_bad_input_one_line_exit_1_no_output_file(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, mutate: Callable[[Path], object], expected: str
) -> None:
    shutil.copy(MODEL, tmp_path / "model.toml")
    shutil.copy(REPORT, tmp_path / "r.csv")
    mutate(tmp_path)
    target = tmp_path / "offsets.csv"
    code, out, err = run(
        capsys, "correct", "--model", str(tmp_path / "model.toml"), "--offsets", str(target), str(tmp_path / "r.csv")
    )
    assert code == 1
    assert expected in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not target.exists() and out == ""


def test_usage_errors_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert run(capsys, "correct", REPORT)[0] == 2
    assert run(capsys, "correct", "--model", MODEL, "--optimizer", "simplex", REPORT)[0] == 2
    assert run(capsys)[0] == 2


def test_model_show_prints_matrices_rank_and_null_space(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "model", "show", MODEL)
    assert code == 0
    assert "R_TF" in out and "R_FD" in out and "rank 9" in out
    assert "−W1 −W2 −W3 −W4 −W5 −W6 −W7 −W8 +T5 +T23" in out
    code, out, _ = run(capsys, "model", "show", MODEL, "--json")
    doc = json.loads(out)
    assert doc["rank"] == 9 and doc["null_space"][0]["T23"] == 1.0


def test_group_without_action_shows_its_help(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "model")
    assert code == 2 and "show" in err and out == ""
    assert run(capsys, "--help")[0] == 0


def gross_copy(tmp_path: Path, deviation: float) -> Path:
    """cycle_01.csv with P1 D1 moved to ``deviation`` (issue 13's gross errors)."""
    lines = (GUIDE_PINS / "cycle_01.csv").read_text().splitlines()
    out = []
    for line in lines:
        if line.startswith("P1 D1,"):
            cells = line.split(",")
            cells[2], cells[3] = f"{25 + deviation:.4f}", f"{deviation:.4f}"
            line = ",".join(cells)
        out.append(line)
    path = tmp_path / f"gross_{abs(deviation):.2f}.csv"
    path.write_text("\n".join(out) + "\n")
    return path


def never_harms(doc: dict[str, Any]) -> None:
    for d in doc["dimensions"]:
        if d["lower"] <= d["deviation"] <= d["upper"]:
            assert d["lower"] <= d["predicted"] <= d["upper"], d["name"]
            assert "out" not in d["flags"]


def test_gross_error_is_given_up_not_paid_for_by_good_dimensions(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    code, out, _err = run(capsys, "correct", "--model", MODEL, "--json", str(gross_copy(tmp_path, -0.25)))
    doc = json.loads(out)
    assert code == 0 and doc["verdict"] == "apply"
    never_harms(doc)
    assert doc["given_up"] == ["P1 D1"]
    assert any(r["rule"] in ("no_harm", "given_up") and "P1D1" in r["dimensions"] for r in doc["rules"])
    p1d1 = doc["dimensions"][0]
    assert {"out_before", "out", "given_up"} <= set(p1d1["flags"])


def test_reject_exit_status_json_still_printed_no_offsets(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    target = tmp_path / "offsets.csv"
    code, out, err = run(
        capsys, "correct", "--model", MODEL, "--json", "--offsets", str(target), str(gross_copy(tmp_path, -0.50))
    )
    assert code == 5
    doc = json.loads(out)
    assert doc["verdict"] == "reject" and not any(doc["corrections"].values())
    assert "P1 D1" in doc["alarm"] and "P1 D1" in err and len(err.strip().splitlines()) == 1
    assert doc["rules"][0]["rule"] == "reject" and "rejected" in doc["dimensions"][0]["flags"]
    assert not target.exists()
    code, out, _ = run(capsys, "correct", "--model", MODEL, str(gross_copy(tmp_path, -0.50)))
    assert code == 5 and "verdict: REJECT" in out


@pytest.mark.needs_shared
def test_calypso_one_dimension_1_2_mm_out(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from conftest import SAMPLES, shared_path

    report = shared_path("cmm-samples", "calypso", "CALYPSO_chr_PruefplanValidierungsbauteil1_16.txt")
    model = SAMPLES / "calypso" / "model.toml"
    code, out, _ = run(capsys, "correct", "--model", str(model), "--json", str(report))
    doc = json.loads(out)
    assert code == 5 and doc["verdict"] == "reject" and "Distanz Z 8mm" in doc["alarm"]
    # with the reject band widened, the 1.2 mm dimension is given up and no good one is harmed
    wide = tmp_path / "model.toml"
    wide.write_text(model.read_text().replace("limit = 0.1\n", "limit = 0.1\n\n[safety]\nreject_band = 5.0\n", 1))
    code, out, _ = run(capsys, "correct", "--model", str(wide), "--json", str(report))
    doc = json.loads(out)
    assert code == 0 and doc["given_up"] == ["Distanz Z 8mm"] and not doc["at_limit"]
    never_harms(doc)


def test_fixed_register_listed_with_zero_and_dead_band_hold(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    text = (GUIDE_PINS / "model.toml").read_text()
    text = text.replace('register = "H23"', 'register = "H23"\nfixed = true')
    (tmp_path / "m.toml").write_text(text + "\n[safety]\ndead_band = 0.05\n")
    code, out, _ = run(capsys, "correct", "--objective", "paper", "--model", str(tmp_path / "m.toml"), "--json", REPORT)
    doc = json.loads(out)
    assert code == 0 and doc["verdict"] == "hold" and [r["rule"] for r in doc["rules"]] == ["dead_band"]
    t23 = next(r for r in doc["registers"] if r["id"] == "T23")
    assert t23 == {**t23, "fixed": True, "delta": 0.0} and "T23" not in doc["corrections"]
    code, out, _ = run(capsys, "correct", "--objective", "paper", "--model", str(tmp_path / "m.toml"), REPORT)
    assert "HOLD" in out and "fixed" in out


def test_controller_program_needs_one_cycle(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    both = tmp_path / "two.csv"
    lines = (GUIDE_PINS / "cycle_01.csv").read_text().splitlines()
    both.write_text("\n".join(lines + (GUIDE_PINS / "cycle_02.csv").read_text().splitlines()[1:]) + "\n")
    code, _, err = run(
        capsys, "correct", "--model", MODEL, "--controller", "fanuc", "--offsets", str(tmp_path / "o.nc"), str(both)
    )
    assert code == 1 and "choose one with --part" in err and not (tmp_path / "o.nc").exists()
    code, _, err = run(
        capsys, "correct", "--model", MODEL, "--controller", "siemens", "--offsets", str(tmp_path / "o.mpf"), REPORT
    )
    assert code == 1 and "siemens: cannot express register 'G58' (W5)" in err


def test_current_offsets_give_absolute_program_and_feed_the_cumulative_limit(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    from conftest import SAMPLES

    sample = SAMPLES / "controllers"
    target = tmp_path / "o.nc"
    code, _, err = run(
        capsys,
        "correct",
        "--model",
        str(sample / "model.toml"),
        "--controller",
        "fanuc",
        "--current",
        str(sample / "current.csv"),
        "--offsets",
        str(target),
        str(sample / "report.csv"),
    )
    assert code == 0, err
    text = target.read_text()
    assert "G91" not in text.replace("G90", "") and "SAFE TO RUN AGAIN" in text
    # H5 wear is at −0.012: with a cumulative limit of 0.015 it may move by −0.003 at most
    model = tmp_path / "m.toml"
    model.write_text(
        (sample / "model.toml")
        .read_text()
        .replace("limit = 0.1\n", "limit = 0.1\n\n[safety]\ncumulative_limit = 0.015\n", 1)
    )
    code, out, _ = run(
        capsys,
        "correct",
        "--model",
        str(model),
        "--current",
        str(sample / "current.csv"),
        "--json",
        str(sample / "report.csv"),
    )
    doc = json.loads(out)
    assert doc["corrections"]["T5"] >= -0.003 - 1e-12 and "T5" in doc["at_limit"]
    assert any(r["rule"] == "cumulative_limit" and "T5" in r["registers"] for r in doc["rules"])


def test_a_wks_entered_wrong_is_held_and_named_on_stderr_and_in_the_json(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """Issue 22: G55 (W2, station P2 at B0) off by 0.35 mm: not a reject; the register and the amount are named."""
    lines = (GUIDE_PINS / "cycle_01.csv").read_text().splitlines()
    moved = {"P2 D1", "P2 D2", "P2 D4"}  # the dimensions W2 moves, each by +1 (model show)
    out = []
    for line in lines:
        cells = line.split(",")
        if cells[0] in moved:
            dev = float(cells[3]) + 0.35
            cells[2], cells[3] = f"{float(cells[1]) + dev:.4f}", f"{dev:.4f}"
        out.append(",".join(cells))
    report = tmp_path / "g55.csv"
    report.write_text("\n".join(out) + "\n")
    target = tmp_path / "o.csv"
    code, text, err = run(capsys, "correct", "--model", MODEL, "--json", "--offsets", str(target), str(report))
    doc = json.loads(text)
    assert code == 0 and doc["verdict"] == "hold" and not any(doc["corrections"].values())
    (rule,) = [r for r in doc["rules"] if r["rule"] == "setup_error"]
    assert rule["registers"] == ["W2"] and "G55 looks off by -0.3" in rule["message"]
    assert doc["alarm"].startswith("SETUP ERROR: G55") and "warning:" in err and "G55 looks off" in err
    assert target.exists()  # a hold: the rows say "leave the offsets as they are"
