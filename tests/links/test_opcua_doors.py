"""The doors that read a control: ``machine read`` (table, JSON, ``--current`` CSV), ``correct --link`` and
``batch --link`` against the OPC UA test control, and the password that never shows anywhere."""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import SAMPLES
from opcua_control import ControlSpec, TestControl, link_toml, running_control

from parsers.current import read_current
from setupfix.cli import main
from setupfix.model import load_model

pytest.importorskip("asyncua")
pytestmark = pytest.mark.slow  # an OPC UA server starts (seconds)

SAMPLE = SAMPLES / "controllers"
MODEL = str(SAMPLE / "model.toml")
REPORT = str(SAMPLE / "report.csv")
#: The control holds what sample_reports/controllers/current.csv says, but H5 (so the file cannot stand in).
VALUES = {"G54.Z": -412.53, "G55.Z": -412.487, "H5": -0.0104, "H12": 0.0035}
MAP = {"G54": {"Z": "G54.Z"}, "G55": {"Z": "G55.Z"}, "H5": {"length": "H5"}, "H12": {"length": "H12"}}
SECRET = "Zq7-secret-pw-91"


@pytest.fixture(scope="module")
def server() -> Iterator[TestControl]:
    with running_control(ControlSpec(dict(VALUES), increment=0.0001)) as control:
        yield control


@pytest.fixture
def control(server: TestControl) -> TestControl:
    server.reset()
    server.users.password = None
    return server


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def link_file(tmp_path: Path, control: TestControl, **keys: object) -> str:
    path = tmp_path / "link.toml"
    path.write_text(link_toml(control, MAP, **keys))
    return str(path)


def test_machine_read_prints_json_and_a_current_csv_that_correct_reads(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    link = link_file(tmp_path, control, machine="mc-07")
    code, out, err = run(capsys, "machine", "read", "--link", link, "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["machine"] == "mc-07" and doc["unit"] == "mm"
    assert {(c["register"], c["axis"]): c["value"] for c in doc["components"]} == {
        ("G54", "Z"): -412.53,
        ("G55", "Z"): -412.487,
        ("H5", "length"): -0.0104,
        ("H12", "length"): 0.0035,
    }
    code, out, err = run(capsys, "machine", "read", "--link", link)
    assert code == 0 and "G54.Z" in out and "-412.530000" in out
    csv = tmp_path / "current.csv"
    code, _, err = run(capsys, "machine", "read", "--link", link, "--model", MODEL, "--out", str(csv))
    assert code == 0, err
    assert read_current(csv, load_model(MODEL)) == {"W1": -412.53, "W2": -412.487, "T5": -0.0104, "T12": 0.0035}
    code, _, err = run(capsys, "machine", "read", "--link", link, "--out", str(csv))
    assert code == 1 and "--out needs --model" in err
    assert not [t for t in threading.enumerate() if t.name == "opcua-link"]  # every link closed its loop


def test_correct_with_link_equals_correct_with_current(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    link = link_file(tmp_path, control)
    current = tmp_path / "current.csv"
    current.write_text("register,value\nG54,-412.53\nG55,-412.487\nH5,-0.0104\nH12,0.0035\n")
    by_link, by_file = tmp_path / "link.nc", tmp_path / "file.nc"
    code, out_link, err = run(capsys, "correct", "--model", MODEL, "--link", link, "--json", REPORT)
    assert code == 0, err
    code, out_file, err = run(capsys, "correct", "--model", MODEL, "--current", str(current), "--json", REPORT)
    assert code == 0, err
    a, b = json.loads(out_link), json.loads(out_file)
    assert a["corrections"] == b["corrections"] and a["verdict"] == b["verdict"] == "apply"
    assert a["link"]["current"] == [
        {"register": "G54", "axis": "Z", "value": -412.53},
        {"register": "G55", "axis": "Z", "value": -412.487},
        {"register": "H5", "axis": "length", "value": -0.0104},
        {"register": "H12", "axis": "length", "value": 0.0035},
    ]
    assert "link" not in b
    for target, source in ((by_link, ("--link", link)), (by_file, ("--current", str(current)))):
        argv = ["correct", "--model", MODEL, *source, "--controller", "fanuc", "--offsets", str(target), REPORT]
        code, _, err = run(capsys, *argv)
        assert code == 0, err
    program = by_link.read_text()
    assert program == by_file.read_text() and "ABSOLUTE VALUES" in program and "WAS -0.0104" in program
    code, _, err = run(capsys, "correct", "--model", MODEL, "--link", link, "--current", str(current), REPORT)
    assert code == 1 and "--link and --current" in err


def test_batch_with_link_equals_batch_with_current(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    link = link_file(tmp_path, control)
    current = tmp_path / "current.csv"
    current.write_text("register,value\nG54,-412.53\nG55,-412.487\nH5,-0.0104\nH12,0.0035\n")
    folder = tmp_path / "reports"
    folder.mkdir()
    (folder / "report.csv").write_bytes(Path(REPORT).read_bytes())
    outs: list[str] = []
    for source in (("--link", link), ("--current", str(current))):
        target = tmp_path / f"o{len(outs)}.csv"
        code, _, err = run(capsys, "batch", "--model", MODEL, str(folder), "--out", str(target), *source)
        assert code == 0, err
        outs.append(target.read_text())
    assert outs[0] == outs[1] and "-412.553" in outs[0]


def test_a_password_never_shows_in_output_logs_or_the_store(
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    control: TestControl,
    caplog: pytest.LogCaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("H1_TEST_PW", SECRET)
    control.users.password = SECRET
    link = link_file(tmp_path, control, user="setter", password_env="H1_TEST_PW")
    caplog.set_level(logging.DEBUG)
    code, _, err = run(capsys, "machine", "read", "--link", link)
    assert code == 1 and "unencrypted session" in err and "--insecure" in err and SECRET not in err
    texts = []
    code, out, err = run(capsys, "machine", "read", "--link", link, "--insecure", "--json")
    assert code == 0, err
    texts += [out, err]
    code, out, err = run(capsys, "correct", "--model", MODEL, "--link", link, "--insecure", "--json", REPORT)
    assert code == 0, err
    texts += [out, err]
    plan = tmp_path / "plan.json"
    plan.write_text(out)
    db = tmp_path / "h.db"
    argv = ["machine", "write", "--link", link, "--model", MODEL, "--plan", str(plan), "--insecure", "--db", str(db)]
    code, out, err = run(capsys, *argv, "--apply", "--json")
    assert code == 0, err
    texts += [out, err]
    control.running = True  # a refusal's message too
    code, out, err = run(capsys, *argv, "--apply")
    assert code == 6
    texts += [out, err]
    assert control.users.seen[-1] == ("setter", SECRET)  # the control did get it
    assert all(SECRET not in t for t in texts)
    assert all(SECRET not in r.getMessage() and SECRET not in str(r.args) for r in caplog.records)
    for f in tmp_path.iterdir():
        assert SECRET.encode() not in f.read_bytes(), f
    from setupfix.links import load_link

    assert SECRET not in repr(load_link(link)) and SECRET not in str(load_link(link).name)
    control.users.password = "another"  # a wrong password: refused, and still not shown
    code, out, err = run(capsys, "machine", "read", "--link", link, "--insecure")
    assert code == 1 and "refused the session" in err and SECRET not in out + err


def test_a_node_named_by_its_namespace_uri_is_read(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    from opcua_control import NAMESPACE

    text = link_toml(control, MAP).replace(control.node("G54.Z"), f"nsu={NAMESPACE};s=G54.Z")
    assert f"nsu={NAMESPACE};s=G54.Z" in text
    link = tmp_path / "link.toml"
    link.write_text(text)
    code, out, err = run(capsys, "machine", "read", "--link", str(link), "--json")
    assert code == 0, err
    assert json.loads(out)["components"][0] == {"register": "G54", "axis": "Z", "value": -412.53, "unit": "mm"}
