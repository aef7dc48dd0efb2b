"""The one corrections-log reader and model check: one bad row, one message, one line, through every door."""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import pytest

from parsers.corrections import check_corrections, log_from_frame, read_corrections_log
from setupfix.cli import main
from setupfix.core.errors import MatchError, ParseError
from setupfix.model import load_model
from setupfix.store import open_store

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
MODEL = GUIDE / "model.toml"
REPORTS = sorted(GUIDE.glob("cycle_0*.csv"))  # 2026-11-02T08:00 … one cycle each
HEAD = "timestamp,register,delta,event\n"
GOOD_ROW = "2026-11-02T07:00:00,W1,0.01,\n"


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


# -- the reader -----------------------------------------------------------------------------------


def test_rows_keep_their_lines_and_the_register_as_written(tmp_path: Path) -> None:
    log = read_corrections_log(
        _write(
            tmp_path / "c.csv",
            HEAD + GOOD_ROW + '\n\n2026-11-02T09:00:00+01:00,"H5",,tool_change\n2026-11-02T10:00:00,G55,-2e-3,\n',
        )
    )
    assert [(r.where.line, r.register, r.event) for r in log.rows] == [
        (2, "W1", "correction"),
        (5, "H5", "tool_change"),
        (6, "G55", "correction"),
    ]
    assert math.isnan(log.rows[1].delta) and log.rows[2].delta == -0.002
    frame = log.frame()
    assert list(frame.columns) == ["timestamp", "register", "delta", "event"]
    assert frame["timestamp"].tolist() == ["2026-11-02T07:00:00", "2026-11-02T09:00:00+01:00", "2026-11-02T10:00:00"]
    checked = check_corrections(log, load_model(MODEL))
    ids = load_model(MODEL).register_ids
    assert [ids[i] for i in checked.registers] == ["W1", "T5", "W2"]
    assert checked.deltas.tolist() == [0.01, 0.0, -0.002]
    assert str(checked.times[1]) == "2026-11-02 08:00:00"  # an offset is converted to UTC


@pytest.mark.parametrize("header", ["Timestamp,Register,Delta", " TIMESTAMP , register ,Delta,Event,comment"])
def test_the_header_is_matched_whatever_its_case(tmp_path: Path, header: str) -> None:
    log = read_corrections_log(_write(tmp_path / "c.csv", f"\ufeff{header}\n2026-11-02T07:00:00,G54,0.01\n"))
    assert [(r.register, r.delta, r.event) for r in log.rows] == [("G54", 0.01, "correction")]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "c.csv:1: empty file"),
        ("timestamp,register\n", "c.csv:1: not a corrections log: missing column(s) delta"),
        ("timestamp,register,delta,Delta\n", "c.csv:1: column 'delta' appears twice"),
        ("timestamp,register,delta\nyesterday,G54,0.1\n", "c.csv:2: timestamp 'yesterday' is not ISO 8601"),
        ("timestamp,register,delta\n,G54,0.1\n", "c.csv:2: empty timestamp"),
        ("timestamp,register,delta\n2026-01-01T00:00:00,,0.1\n", "c.csv:2: empty register"),
        ("timestamp,register,delta\n2026-01-01T00:00:00,G54,\n", "c.csv:2: a correction needs a delta"),
        ("timestamp,register,delta\n2026-01-01T00:00:00,G54,nan\n", "c.csv:2: column 'delta': expected a number"),
        ("timestamp,register,delta\n2026-01-01T00:00:00,G54,1_0\n", "c.csv:2: column 'delta': expected a number"),
        ("timestamp,register,delta\n2026-01-01T00:00:00,G54,0,05\n", "c.csv:2: 4 cells but 3 columns in the header"),
        (
            "timestamp,register,delta,event\n2026-01-01T00:00:00,H5,0.1,tool_change\n",
            "c.csv:2: a tool change carries no",
        ),
        ("timestamp,register,delta,event\n2026-01-01T00:00:00,H5,,wear\n", "c.csv:2: unknown event 'wear'"),
        (
            "timestamp,register,delta\n2026-01-01T00:00:00,G54,0.1\n2026-01-01T01:00:00+01:00,G54,0.1\n",
            "c.csv:3: G54 correction at 2026-01-01T01:00:00+01:00 given twice (also at line 2)",
        ),
    ],
)
def test_a_bad_log_is_named_at_its_line(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(ParseError, match=re.escape(message)):
        read_corrections_log(_write(tmp_path / "c.csv", text))


def test_not_utf8_is_named_at_its_line(tmp_path: Path) -> None:
    (tmp_path / "c.csv").write_bytes(b"timestamp,register,delta\n2026-01-01T00:00:00,G\xe454,0.1\n")
    with pytest.raises(ParseError, match=r"c.csv:2: not UTF-8"):
        read_corrections_log(tmp_path / "c.csv")


def test_the_model_check_names_the_row(tmp_path: Path) -> None:
    model = load_model(MODEL)
    log = read_corrections_log(_write(tmp_path / "c.csv", HEAD + GOOD_ROW + "2026-11-02T07:30:00,G54,,tool_change\n"))
    with pytest.raises(MatchError, match=r"c.csv:3: tool change of W1, which is not a tool"):
        check_corrections(log, model)
    twice = read_corrections_log(_write(tmp_path / "t.csv", HEAD + GOOD_ROW + "2026-11-02T07:00:00,G54,0.02,\n"))
    with pytest.raises(
        MatchError,
        match=r"t.csv:3: W1 \(G54\) correction at 2026-11-02T07:00:00 given twice "
        r"\(also at line 2\)",
    ):
        check_corrections(twice, model)
    stored = log_from_frame(log.frame().iloc[:1].assign(register="G99"), "h.db#corrections")
    with pytest.raises(MatchError, match=r"h.db#corrections: <row 1>: unknown register 'G99'"):
        check_corrections(stored, model)


# -- one bad row through every door ---------------------------------------------------------------

BAD_ROWS = {
    "unknown register": "2026-11-02T07:30:00,G99,0.01,\n",
    "bad timestamp": "yesterday,W1,0.01,\n",
    "decimal comma": "2026-11-02T07:30:00,W1,0,01,\n",
    "unknown event": "2026-11-02T07:30:00,T5,,wear\n",
    "no delta": "2026-11-02T07:30:00,W1,,\n",
    "tool change of a WKS": "2026-11-02T07:30:00,G54,,tool_change\n",
    "given twice": "2026-11-02T07:00:00,W1,0.01,\n",  # a store keeps one row, a sum counts two
    "given twice by name": "2026-11-02T07:00:00,G54,0.02,\n",
}


def _door(door: str, tmp_path: Path, log: Path) -> list[str]:
    """The command line of one door taking the corrections log ``log``."""
    db = tmp_path / "h.db"
    folder = tmp_path / "series"
    if door.endswith("folder"):  # the log found beside the reports
        folder.mkdir()
        for r in REPORTS:
            shutil.copy(r, folder / r.name)
        shutil.copy(log, folder / "corrections.csv")
    if door == "diagnose --db":
        assert main(["history", "import", "--db", str(db), *map(str, REPORTS)]) == 0
    return {
        "history import": [
            "history",
            "import",
            "--db",
            str(db),
            "--model",
            str(MODEL),
            "--corrections",
            str(log),
            *map(str, REPORTS),
        ],
        "history import folder": ["history", "import", "--db", str(db), "--model", str(MODEL), str(folder)],
        "diagnose": ["diagnose", "--model", str(MODEL), "--no-walk", "--corrections", str(log), *map(str, REPORTS)],
        "diagnose folder": ["diagnose", "--model", str(MODEL), "--no-walk", str(folder)],
        "diagnose --db": ["diagnose", "--model", str(MODEL), "--no-walk", "--db", str(db), "--corrections", str(log)],
    }[door]


@pytest.mark.parametrize("bad", list(BAD_ROWS))
@pytest.mark.parametrize(
    "door", ["history import", "history import folder", "diagnose", "diagnose folder", "diagnose --db"]
)
def test_one_bad_row_one_message_one_line_through_every_door(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], door: str, bad: str
) -> None:
    log = _write(tmp_path / "log.csv", HEAD + GOOD_ROW + "\n" + BAD_ROWS[bad])  # the bad row is line 4
    argv = _door(door, tmp_path, log)
    capsys.readouterr()
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 1 and out == "" and err.count("\n") == 1, err
    shown = log if "folder" not in door else tmp_path / "series" / "corrections.csv"
    assert err.startswith(f"error: {shown}:4: ")
    # the same message whatever the door: compared with the reader and the model check called directly
    try:
        check_corrections(read_corrections_log(log), load_model(MODEL))
    except (ParseError, MatchError) as exc:
        expected = f"error: {exc}".replace(str(log), str(shown))
    else:
        pytest.fail("the log was accepted")
    assert err.strip() == expected
    if door.startswith("history"):  # nothing was stored
        with open_store(tmp_path / "h.db") as store:
            assert store.reports() == [] and store.corrections().empty


def test_a_bad_row_kept_in_a_store_is_named_by_the_store_and_row(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Imported without a model (so unchecked), the row is refused where the store is read, named alike."""
    db = tmp_path / "h.db"
    log = _write(tmp_path / "log.csv", HEAD + GOOD_ROW + BAD_ROWS["unknown register"])
    assert main(["history", "import", "--db", str(db), "--corrections", str(log), *map(str, REPORTS)]) == 0
    capsys.readouterr()
    assert main(["diagnose", "--model", str(MODEL), "--no-walk", "--db", str(db)]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"error: {db}#corrections: <row 2>: unknown register 'G99' (model registers: W1,")


def test_the_capitalised_header_is_accepted_by_every_door_with_the_same_result(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = HEAD + GOOD_ROW + "2026-11-02T09:30:00,H5,-0.004,\n"
    lower = _write(tmp_path / "lower.csv", text)
    upper = _write(tmp_path / "upper.csv", text.replace(HEAD, "Timestamp,Register,Delta,Event\n"))
    outs = []
    for log in (lower, upper):
        assert (
            main(
                [
                    "diagnose",
                    "--model",
                    str(MODEL),
                    "--no-walk",
                    "--json",
                    "--corrections",
                    str(log),
                    *map(str, REPORTS),
                ]
            )
            == 0
        )
        outs.append(capsys.readouterr().out)
    assert outs[0] == outs[1]
    db = tmp_path / "h.db"
    assert main(["history", "import", "--db", str(db), "--model", str(MODEL), "--corrections", str(upper)]) == 0
    with open_store(db) as store:
        assert store.corrections()["register"].tolist() == ["W1", "H5"]
