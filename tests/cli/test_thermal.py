"""``setupfix thermal fit|predict|evaluate`` in-process on the bundled simulated sample."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import setupfix.cli as cli

SAMPLES = Path(__file__).resolve().parents[2] / "sample_reports" / "thermal"
TRAIN = str(SAMPLES / "train_variable.csv")
TEST = str(SAMPLES / "test_variable.csv")


@pytest.fixture(autouse=True)
def only_thermal(monkeypatch: pytest.MonkeyPatch) -> None:
    # Other sub-commands are written in parallel; test this one on its own.
    monkeypatch.setattr(cli, "COMMAND_MODULES", ("setupfix.cli.thermal",))


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def short_train(tmp_path_factory: pytest.TempPathFactory) -> str:
    """The first half of the training log: kalman fits in a fraction of the time, as well (0.0043 mm)."""
    path = tmp_path_factory.mktemp("thermal") / "train_half.csv"
    path.write_text("\n".join((SAMPLES / "train_variable.csv").read_text().splitlines()[:721]) + "\n")
    return str(path)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["mra", "grey-ls", "kalman"])
def test_evaluate_json_contract(capsys: pytest.CaptureFixture[str], method: str, short_train: str) -> None:
    budget = ["--iterations", "20"] if method == "kalman" else []
    train = short_train if method == "kalman" else TRAIN
    code, out, err = run(
        capsys,
        "thermal",
        "evaluate",
        "--method",
        method,
        "--train",
        train,
        "--test",
        TEST,
        "--target",
        "error_z",
        "--seed",
        "1",
        "--json",
        *budget,
    )
    assert code == 0, err
    doc = json.loads(out)
    assert {"method", "rmse", "max_residual", "efficiency", "n_test"} <= doc.keys()
    assert doc["method"] == method and doc["n_test"] == 1439
    assert doc["rmse"] < 0.006 and doc["efficiency"] > 0.95  # mm; the drift reaches 0.09 mm
    assert doc["max_residual"] >= doc["rmse"]


@pytest.mark.slow
def test_fit_then_predict(capsys: pytest.CaptureFixture[str], tmp_path: Path, short_train: str) -> None:
    model = tmp_path / "kalman.json"
    code, out, err = run(
        capsys,
        "thermal",
        "fit",
        "--method",
        "kalman",
        short_train,
        "--target",
        "error_z",
        "-o",
        str(model),
        "--seed",
        "0",
        "--iterations",
        "20",
    )
    assert code == 0, err
    assert "model written" in out
    assert json.loads(model.read_text())["format"] == "setupfix-thermal-model"
    csv_out = tmp_path / "pred.csv"
    code, out, err = run(capsys, "thermal", "predict", "--model", str(model), TEST, "-o", str(csv_out), "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["n"] == 1440 and doc["rmse"] < 0.006
    lines = csv_out.read_text().splitlines()
    assert lines[0] == "timestamp,predicted_error_z,error_z" and len(lines) == 1441
    code, out, _ = run(capsys, "thermal", "predict", "--model", str(model), TEST, "--sensors-failed", "--json")
    assert code == 0 and json.loads(out)["rmse"] < 0.015


def test_bad_input_is_one_line_with_file_and_line(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bad = tmp_path / "log.csv"
    text = (SAMPLES / "train_variable.csv").read_text().splitlines()
    text[36] = text[36].replace(text[36].split(",")[1], "n/a", 1)
    bad.write_text("\n".join(text) + "\n")
    code, out, err = run(
        capsys, "thermal", "fit", "--method", "mra", str(bad), "--target", "error_z", "-o", str(tmp_path / "m.json")
    )
    assert code == 1 and out == ""
    assert err.count("\n") == 1 and "log.csv:37: non-numeric value 'n/a' in column 'spindle_motor'" in err
    assert not (tmp_path / "m.json").exists()


def test_missing_columns_and_usage(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, _, err = run(
        capsys, "thermal", "evaluate", "--method", "mra", "--train", TRAIN, "--test", TEST, "--target", "nope"
    )
    assert code == 1 and "target column 'nope'" in err
    code, _, err = run(capsys, "thermal", "fit", "--method", "magic", TRAIN, "--target", "error_z", "-o", "x.json")
    assert code == 2
    code, _, err = run(capsys, "thermal", "predict", "--model", str(tmp_path / "none.json"), TEST)
    assert code == 1 and "none.json" in err


def _log_with(tmp_path: Path, line: int, column: int, value: str) -> str:
    rows = (SAMPLES / "train_variable.csv").read_text().splitlines()[:200]
    cells = rows[line - 1].split(",")
    cells[column] = value
    rows[line - 1] = ",".join(cells)
    path = tmp_path / "log.csv"
    path.write_text("\n".join(rows) + "\n")
    return str(path)


@pytest.mark.parametrize(
    ("argv", "code", "message"),
    [
        (["--inputs", "error_z"], 1, "'error_z' is both the target and a temperature input"),
        (["--iterations", "-5", "--method", "grey-cs"], 2, "--iterations: must be in [1, 100000], got -5"),
        (["--seed", "-1"], 2, "--seed: must be a whole number >= 0"),
        (["--bound", "-1", "--method", "grey-cs"], 2, "--bound: must be a positive finite number"),
        (["--iterations", "5"], 1, "--iterations does not apply to the mra method"),
        (["--interval", "0"], 2, "--interval: must be a positive"),
    ],
)
def test_bad_options_are_refused(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, argv: list[str], code: int, message: str
) -> None:
    args = ["thermal", "fit", "--method", "mra", TRAIN, "--target", "error_z", "-o", str(tmp_path / "m.json")]
    if "--method" in argv:
        i = argv.index("--method")
        args[3] = argv[i + 1]
        argv = argv[:i] + argv[i + 2 :]
    got, out, err = run(capsys, *args, *argv)
    assert got == code and message in err and out == ""
    assert not (tmp_path / "m.json").exists()


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("1e308", "outside [-273.15, 2000]"),
        ("1e300", "outside"),
        ("1e306", "outside"),
        ("2_1", "non-numeric value '2_1'"),
        ("nan", "non-numeric value 'nan'"),
    ],
)
def test_hostile_cells_are_one_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, value: str, message: str
) -> None:
    log = _log_with(tmp_path, 40, 1, value)
    code, out, err = run(
        capsys, "thermal", "fit", "--method", "grey-ls", log, "--target", "error_z", "-o", str(tmp_path / "m.json")
    )
    assert code == 1 and out == "" and err.count("\n") == 1
    assert "log.csv:40:" in err and message in err


def test_constant_target_and_directory_output(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    rows = (SAMPLES / "train_variable.csv").read_text().splitlines()[:100]
    const = tmp_path / "c.csv"
    const.write_text("\n".join(rows[:1] + [",".join([*r.split(",")[:-1], "0.1"]) for r in rows[1:]]) + "\n")
    code, _out, err = run(
        capsys, "thermal", "fit", "--method", "mra", str(const), "--target", "error_z", "-o", str(tmp_path / "m.json")
    )
    assert code == 1 and "constant" in err and "e+29" not in err
    code, _out, err = run(
        capsys, "thermal", "fit", "--method", "mra", TRAIN, "--target", "error_z", "-o", str(tmp_path)
    )
    assert code == 1 and "internal error" not in err


def test_units_seed_and_corrupt_model(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    model = tmp_path / "g.json"
    code, out, err = run(
        capsys,
        "thermal",
        "fit",
        "--method",
        "grey-pso",
        "--iterations",
        "2",
        TRAIN,
        "--target",
        "error_z",
        "--unit",
        "mm",
        "--inputs",
        "spindle_motor,bearing",
        "-o",
        str(model),
    )
    assert code == 0 and "seed 0" in out and " mm" in out
    assert "warning:" in err and "E = " in err  # two PSO iterations fit worse than the mean: flagged
    code, out, _ = run(capsys, "thermal", "predict", "--model", str(model), TEST)
    assert code == 0 and " mm relative to the model's reference state" in out
    model.write_bytes(model.read_bytes().replace(b'"theta_"', b'"th\xffeta_"'))
    code, out, err = run(capsys, "thermal", "predict", "--model", str(model), TEST)
    assert code == 1 and "g.json" in err and "internal error" not in err


def test_warm_test_log_anchor_and_interval(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    rows = (SAMPLES / "train_variable.csv").read_text().splitlines()
    (tmp_path / "a.csv").write_text("\n".join(rows[:721]) + "\n")
    (tmp_path / "b.csv").write_text("\n".join(rows[:1] + rows[721:]) + "\n")
    args = [
        "thermal",
        "evaluate",
        "--method",
        "mra",
        "--train",
        str(tmp_path / "a.csv"),
        "--test",
        str(tmp_path / "b.csv"),
        "--target",
        "error_z",
        "--unit",
        "mm",
        "--json",
    ]
    code, out, err = run(capsys, *args)
    doc = json.loads(out)
    assert code == 0 and doc["unit"] == "mm" and doc["rmse"] < 0.012  # as if continuous; the drift there is ~0.036
    assert "from the model's reference state" in err and any("reference state" in w for w in doc["warnings"])
    code, out, _ = run(capsys, *args, "--anchor", "first")
    assert code == 0 and json.loads(out)["rmse"] < 0.012
    plain = tmp_path / "plain.csv"  # no timestamp: the interval gives the time
    plain.write_text("\n".join(",".join(r.split(",")[1:]) for r in rows[:300]) + "\n")
    code, _, err = run(
        capsys,
        "thermal",
        "fit",
        "--method",
        "grey-ls",
        str(plain),
        "--target",
        "error_z",
        "-o",
        str(tmp_path / "m.json"),
    )
    assert code == 1 and "--interval SECONDS" in err
    code, _, err = run(
        capsys,
        "thermal",
        "fit",
        "--method",
        "grey-ls",
        str(plain),
        "--target",
        "error_z",
        "--interval",
        "10",
        "-o",
        str(tmp_path / "m.json"),
    )
    assert code == 0, err
    assert json.loads((tmp_path / "m.json").read_text())["sample_interval_s"] == 10.0


@pytest.mark.needs_shared
def test_real_xlsx_logs(capsys: pytest.CaptureFixture[str]) -> None:
    from conftest import shared_path

    folder = shared_path("thermal-data", "gooddash")
    code, out, err = run(
        capsys,
        "thermal",
        "evaluate",
        "--method",
        "mra",
        "--train",
        str(folder / "data_ex1.xlsx"),
        "--test",
        str(folder / "data_ex2.xlsx"),
        "--target",
        "W",
        "--interval",
        "60",
        "--unit",
        "um",
        "--json",
    )
    assert code == 0, err
    doc = json.loads(out)
    assert len(doc["inputs"]) == 22 and doc["n_test"] == 72 and doc["rmse"] < 2.5  # µm, as from the CSV copies
