"""`setupfix simulate` and `setupfix diagnose` end to end, bad input on purpose."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest
from conftest import GUIDE_PINS

from setupfix.cli import main

MODEL = str(GUIDE_PINS / "model.toml")
CONTRACT = {"cycles", "rms_before", "rms_after", "max_before", "max_after", "effects", "next_correction"}


def run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def series(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("series")
    code = main(
        [
            "simulate",
            "--model",
            MODEL,
            "--out",
            str(out),
            "--seed",
            "4",
            "--cycles",
            "30",
            "--effect",
            "kind=wear,register=T5,magnitude=-0.001",
        ]
    )
    assert code == 0
    return out


def test_simulate_writes_the_canonical_files(series: Path) -> None:
    names = sorted(p.name for p in series.iterdir())
    assert names == ["corrections.csv", "measurements.csv", "temperatures.csv", "truth.json"]
    head = (series / "corrections.csv").read_text().splitlines()[0]
    assert head == "timestamp,register,delta,event"
    assert "tool_change" in (series / "corrections.csv").read_text()
    truth = json.loads((series / "truth.json").read_text())
    assert truth["hidden_effects"][0]["kind"] == "wear"


@pytest.mark.slow
def test_diagnose_json_contract_and_augment(series: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    aug = tmp_path / "aug.toml"
    code, out, err = run(
        capsys,
        "diagnose",
        "--model",
        MODEL,
        "--corrections",
        series / "corrections.csv",
        "--temperatures",
        series / "temperatures.csv",
        "--augment",
        aug,
        "--json",
        series / "measurements.csv",
    )
    assert code == 0, err
    doc = json.loads(out)
    assert doc.keys() >= CONTRACT
    assert doc["cycles"] == 30
    assert [(e["kind"], e["target"]) for e in doc["effects"]] == [("wear", "T5 ~ parts since change")]
    assert doc["rms_after"] < doc["rms_before"]
    assert set(doc["next_correction"]) == {f"W{i}" for i in range(1, 9)} | {"T5", "T23"}
    wf = doc["walk_forward"]
    assert wf["augmented"]["mean_budget"] > wf["declared"]["mean_budget"]
    effects = tomllib.loads(aug.read_text())["effects"]
    assert effects["E1"]["kind"] == "wear" and effects["E1"]["register"] == "T5"
    # the augmented model loads, and a second diagnosis with it finds nothing more
    code, out, err = run(capsys, "diagnose", "--model", aug, "--json", "--no-walk", series)
    assert code == 0, err
    assert json.loads(out)["effects"] == []
    # correct forecasts the next cycle with the augmented model: one more cycle of T5 wear (C[T5, P1 D1] = 1)
    code, out, err = run(capsys, "correct", "--model", aug, "--json", str(GUIDE_PINS / "cycle_01.csv"))
    assert code == 0, err
    row = json.loads(out)["dimensions"][0]
    assert row["name"] == "P1 D1" and row["deviation"] == pytest.approx(-0.0309)  # as measured (the contract)
    assert row["estimate"] == pytest.approx(-0.0309 + effects["E1"]["estimate"])  # what was corrected


def test_bad_corrections_log_is_refused_with_its_line(
    series: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "log.csv"
    bad.write_text("timestamp,register,delta\n2026-11-02T06:00:00,W1,0.01\n2026-11-02T07:00:00,G99,0.01\n")
    aug = tmp_path / "aug.toml"
    code, out, err = run(
        capsys, "diagnose", "--model", MODEL, "--corrections", bad, "--augment", aug, series / "measurements.csv"
    )
    assert code == 1
    assert err.startswith(f"error: {bad}:3: unknown register 'G99'") and err.count("\n") == 1
    assert not aug.exists() and out == ""


@pytest.mark.parametrize(
    "effect",
    [
        "kind=creep,magnitude=1",
        "kind=drift",
        "kind=drift,magnitude=x",
        "kind=wear,register=T99,magnitude=0.001",
        "kind=position,axis=x,magnitude=1e-4",
        "kind=level,register=T5,magnitude=0.01",
        "kind=level,at=0,magnitude=0.01",
        "kind=level,at=99,magnitude=0.01",
        "kind=drift,at=3,magnitude=0.001",
    ],
)
def test_simulate_refuses_bad_effects(effect: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _out, err = run(capsys, "simulate", "--model", MODEL, "--out", tmp_path / "o", "--effect", effect)
    assert code == 1 and err.startswith("error: ") and err.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_bad_timestamp_in_temperatures(series: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "temps.csv"
    bad.write_text("timestamp,spindle\n2026-11-02T06:00:00,20.1\nyesterday,20.2\n")
    code, _, err = run(capsys, "diagnose", "--model", MODEL, "--temperatures", bad, series / "measurements.csv")
    assert code == 1 and f"{bad}:3: timestamp 'yesterday' is not ISO 8601" in err  # the one log reader


@pytest.mark.slow
def test_diagnose_from_the_history_store_equals_the_files(
    series: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "h.db"
    code = main(
        [
            "history",
            "import",
            "--db",
            str(db),
            "--corrections",
            str(series / "corrections.csv"),
            "--temperatures",
            str(series / "temperatures.csv"),
            str(series / "measurements.csv"),
        ]
    )
    assert code == 0
    capsys.readouterr()
    code, out, err = run(capsys, "diagnose", "--model", MODEL, "--db", db, "--json", "--no-walk")
    assert code == 0, err
    code, out2, err = run(capsys, "diagnose", "--model", MODEL, "--json", "--no-walk", series)
    a, b = json.loads(out), json.loads(out2)
    assert a["effects"] == b["effects"] and a["rms_before"] == b["rms_before"]
    assert a["next_correction"] == b["next_correction"]
    from setupfix.store import open_store

    with open_store(db) as store:  # the recommendation is kept with what it came from
        (rec,) = store.recommendations()
    assert rec.inputs["command"] == "diagnose" and rec.result["next_correction"] == a["next_correction"]


def test_thermal_model_prediction_is_a_candidate_channel(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A thermal model saved by `thermal fit` enters as one more channel; here it is linear in the
    spindle temperature, so the report says the two cannot be told apart."""
    import numpy as np
    import pandas as pd

    loop = GUIDE_PINS.parent / "closed_loop"
    temps = pd.read_csv(loop / "temperatures.csv")
    temps["error_z"] = 0.003 * (temps["spindle"] - 20) + np.random.default_rng(0).normal(0, 2e-4, len(temps))
    log = tmp_path / "temps.csv"
    temps.to_csv(log, index=False)
    saved = tmp_path / "mra.json"
    assert (
        main(
            [
                "thermal",
                "fit",
                "--method",
                "mra",
                "--target",
                "error_z",
                "--unit",
                "mm",
                "--inputs",
                "spindle",
                "-o",
                str(saved),
                str(log),
            ]
        )
        == 0
    )
    capsys.readouterr()
    code, out, err = run(
        capsys,
        "diagnose",
        "--model",
        MODEL,
        "--corrections",
        loop / "corrections.csv",
        "--temperatures",
        log,
        "--thermal",
        saved,
        "--json",
        "--no-walk",
        loop / "measurements.csv",
    )
    assert code == 0, err
    effects = json.loads(out)["effects"]
    assert [e["kind"] for e in effects] == ["thermal"]
    assert {effects[0]["target"], *(a.split(": ", 1)[1] for a in effects[0]["alike"])} == {
        "all tools ~ spindle",
        "all tools ~ mra prediction",
    }


@pytest.mark.slow
def test_a_series_without_its_corrections_log_says_so_and_names_the_log_beside_it(
    series: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = run(capsys, "diagnose", "--model", MODEL, "--json", "--no-walk", series / "measurements.csv")
    assert code == 0, err
    notes = [n for n in json.loads(out)["notes"] if n.startswith("no corrections log")]
    assert len(notes) == 1 and f"{series / 'corrections.csv'} lies beside the reports" in notes[0]
    code, out, err = run(capsys, "diagnose", "--model", MODEL, "--json", "--no-walk", series)  # the folder: used
    assert code == 0, err
    assert not [n for n in json.loads(out)["notes"] if n.startswith("no corrections log")]


def test_one_part_reported_twice_counts_once(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The bundled cycle 01 comes as CSV, DMIS and QIF: three files, one machined part.  Counted three
    times it made drift and wear look significant; it counts once, said in a note."""
    code, out, err = run(capsys, "diagnose", "--model", MODEL, "--json", "--no-walk", GUIDE_PINS)
    assert code == 0, err
    doc = json.loads(out)
    assert doc["cycles"] == 5 and doc["effects"] == []
    assert sum("are one part" in n and "the same deviations" in n for n in doc["notes"]) == 2
    # measured twice with other values: the later file is used, and the note says by how much they differ
    text = (GUIDE_PINS / "cycle_02.csv").read_text()
    (tmp_path / "a.csv").write_text(text)
    assert "P1 D1,25.0000,25.0306,0.0306," in text
    (tmp_path / "b.csv").write_text(text.replace("P1 D1,25.0000,25.0306,0.0306,", "P1 D1,25.0000,25.0206,0.0206,"))
    (tmp_path / "c.csv").write_text((GUIDE_PINS / "cycle_03.csv").read_text())
    code, out, err = run(capsys, "diagnose", "--model", MODEL, "--json", "--no-walk", tmp_path)
    assert code == 0, err
    doc = json.loads(out)
    assert doc["cycles"] == 2
    assert any(
        "a.csv:cycle 02 and b.csv:cycle 02 are one part" in n
        and "differing by up to 0.01)" in n
        and "b.csv is used once" in n
        for n in doc["notes"]
    )


@pytest.mark.slow
def test_diagnose_json_says_which_model_the_next_correction_comes_from(
    series: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A real wear of T5: the augmented model beat EWMA on the centre distance with no more out of tolerance,
    so the next correction comes from it; the walk's centre scores are in the JSON."""
    code, out, err = run(
        capsys,
        "diagnose",
        "--model",
        MODEL,
        "--corrections",
        series / "corrections.csv",
        "--temperatures",
        series / "temperatures.csv",
        "--json",
        series / "measurements.csv",
    )
    assert code == 0, err
    doc = json.loads(out)
    wf = doc["walk_forward"]
    for name in ("declared", "augmented", "ewma", "none"):
        assert wf[name]["centre_mean_abs"] <= wf[name]["centre_rms"]
    assert wf["augmented"]["centre_rms"] < wf["ewma"]["centre_rms"]
    assert wf["augmented"]["out_of_tolerance"] <= wf["ewma"]["out_of_tolerance"]
    assert doc["next_from"] == "augmented" and "beat ewma" in doc["next_from_reason"]
    assert all(doc["next_correction"].get(r, 0.0) == 0.0 for r in doc["held_centred"])


@pytest.mark.slow
def test_diagnose_text_prints_the_centre_scores_and_where_the_next_correction_comes_from(
    series: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = run(
        capsys,
        "diagnose",
        "--model",
        MODEL,
        "--corrections",
        series / "corrections.csv",
        "--temperatures",
        series / "temperatures.csv",
        series / "measurements.csv",
    )
    assert code == 0, err
    code, js, _ = run(
        capsys,
        "diagnose",
        "--model",
        MODEL,
        "--corrections",
        series / "corrections.csv",
        "--temperatures",
        series / "temperatures.csv",
        "--json",
        series / "measurements.csv",
    )
    doc = json.loads(js)
    aug = doc["walk_forward"]["augmented"]
    line = next(ln for ln in out.splitlines() if ln.startswith("  augmented"))
    assert f"centre {aug['centre_rms']:.4f} / {aug['centre_mean_abs']:.4f}" in line
    assert f"next correction from: {doc['next_from']} ({doc['next_from_reason']})" in out


@pytest.mark.slow
def test_simulate_level_step_at_a_cycle_is_found_there(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "s"
    code, _o, err = run(
        capsys,
        "simulate",
        "--model",
        MODEL,
        "--out",
        out,
        "--seed",
        "2",
        "--cycles",
        "30",
        "--effect",
        "kind=level,register=T5,at=18,magnitude=0.02",
        "--json",
    )
    assert code == 0, err
    truth = json.loads((out / "truth.json").read_text())
    code, js, err = run(
        capsys,
        "diagnose",
        "--model",
        MODEL,
        "--corrections",
        out / "corrections.csv",
        "--no-walk",
        "--json",
        out / "measurements.csv",
    )
    assert code == 0, err
    level = [e for e in json.loads(js)["effects"] if e["kind"] == "level"]
    assert truth["hidden_effects"][0]["kind"] == "level"
    assert level and level[0]["target"].startswith("T5 step at") and level[0]["cycle"].endswith("18")


def test_the_next_correction_names_the_controller_registers_and_notes_are_capped(
    capsys: pytest.CaptureFixture[str], series: Path
) -> None:
    """Registers as a person types them (G54 Z, H5), not model IDs; at most five notes unless --verbose."""
    from setupfix.model import load_model
    from setupfix.views.analysis import MAX_NOTES, register_labels

    labels = register_labels(load_model(MODEL))
    assert labels["W1"] == "G54 Z" and labels["T5"] == "H5"
    args = ("diagnose", "--model", MODEL, str(series / "measurements.csv"), "--no-walk")
    code, out, _ = run(capsys, *args, "--corrections", series / "corrections.csv")
    assert code == 0
    (line,) = [x for x in out.splitlines() if x.startswith("next correction:")]
    moved = [item.rsplit(" ", 1)[0] for item in line.removeprefix("next correction: ").split(", ")]
    assert line.endswith("none") or set(moved) <= set(labels.values())
    code, terse, _ = run(capsys, *args)  # no corrections log: more notes
    code, verbose, _ = run(capsys, *args, "--verbose")
    notes = [x for x in verbose.splitlines() if x.startswith("note: ")]
    shown = [x for x in terse.splitlines() if x.startswith("note: ")]
    assert shown == notes[:MAX_NOTES]
    if len(notes) > MAX_NOTES:
        assert f"... and {len(notes) - MAX_NOTES} more note(s): --verbose shows them" in terse


def test_register_labels_of_a_multi_axis_model() -> None:
    from setupfix.model import load_model
    from setupfix.views.analysis import next_correction_text, register_labels

    model = load_model(Path(__file__).parents[2] / "sample_reports" / "two_station_xyz" / "model.toml")
    labels = register_labels(model)
    assert labels["W1.X"] == "G54 X" and labels["W1.C"] == "G54 C" and labels["T1"] == "H1" and labels["T1.R"] == "D1"
    assert next_correction_text(model, {"W1.X": 0.013, "T1": -0.192, "W2.Y": 0.0}) == "G54 X +0.0130, H1 -0.1920"
