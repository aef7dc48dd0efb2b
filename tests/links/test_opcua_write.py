"""``machine write`` against a control that behaves like one (``tests/opcua_control.py``): every path of
the spec's guarded sequence, through the command line, with the audit rows checked on SQLite.

The control holds the ``sample_reports/controllers`` model's registers (one axis, Z, mm): G54 and G55
(geometry), H5 and H12 (wear); ``IN.*`` is the same table in inch, ``RO.H12`` a read-only node.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from conftest import SAMPLES
from opcua_control import ControlSpec, TestControl, free_port, link_toml
from pgserver import pg_url  # noqa: F401 - the fixture

from setupfix.cli import main
from setupfix.store import open_store
from setupfix.store.link_audit import LinkAttempt

pytest.importorskip("asyncua")
pytestmark = pytest.mark.slow  # an OPC UA server starts (seconds)

SAMPLE = SAMPLES / "controllers"
MODEL = str(SAMPLE / "model.toml")
REPORT = str(SAMPLE / "report.csv")
#: The control's table (mm, increment 0.0001 mm) and the same in inch (increment 0.0001 inch).
VALUES = {"G54.Z": -412.53, "G55.Z": -412.487, "H5": -0.012, "H12": 0.0035, "RO.H12": 0.0035}
INCH = {f"IN.{k}": v / 25.4 for k, v in VALUES.items() if not k.startswith("RO")}
MAP = {"G54": {"Z": "G54.Z"}, "G55": {"Z": "G55.Z"}, "H5": {"length": "H5"}, "H12": {"length": "H12"}}
#: The corrections correct gives on the report with these current values (the --current test shows them).
CHANGES = {"G54.Z": -0.023, "G55.Z": 0.022, "H5": -0.009, "H12": 0.002}


@pytest.fixture(scope="module")
def server() -> Iterator[TestControl]:
    spec = ControlSpec(
        {**VALUES, **INCH},
        increment=0.0001,
        increments={k: 0.0001 for k in INCH},
        clamp={},
        read_only=frozenset({"RO.H12"}),
    )
    control = TestControl(spec)
    control.start()
    yield control
    control.close()


@pytest.fixture
def control(server: TestControl) -> TestControl:
    server.reset()
    server.spec.clamp.clear()
    return server


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def write_link(tmp_path: Path, control: TestControl, registers: Any = None, **link: Any) -> str:
    path = tmp_path / "link.toml"
    path.write_text(link_toml(control, MAP if registers is None else registers, **link))
    return str(path)


def make_plan(capsys: pytest.CaptureFixture[str], tmp_path: Path, link: str) -> Path:
    code, out, err = run(capsys, "correct", "--model", MODEL, "--link", link, "--json", REPORT)
    assert code == 0, err
    plan = tmp_path / "plan.json"
    plan.write_text(out)
    return plan


def attempts(db: Path) -> list[LinkAttempt]:
    with open_store(db) as store:
        return store.link_attempts(every_machine=True)


def write(
    capsys: pytest.CaptureFixture[str], link: str, plan: Path, db: Path, *extra: str
) -> tuple[int, dict[str, Any], str]:
    code, out, err = run(
        capsys,
        "machine",
        "write",
        "--link",
        link,
        "--model",
        MODEL,
        "--plan",
        str(plan),
        "--db",
        str(db),
        "--json",
        *extra,
    )
    return code, json.loads(out), err


def test_dry_run_shows_the_diff_and_writes_nothing(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    link = write_link(tmp_path, control)
    plan = make_plan(capsys, tmp_path, link)
    db = tmp_path / "h.db"
    code, doc, err = write(capsys, link, plan, db)
    assert code == 0, err
    assert doc["outcome"] == "dry_run" and doc["dry_run"] is True and control.writes == []
    rows = {(c["register"], c["axis"]): c for c in doc["components"]}
    assert rows[("G54", "Z")]["before"] == -412.53 and rows[("G54", "Z")]["change"] == -0.023
    assert rows[("G54", "Z")]["new"] == -412.553 and rows[("H12", "length")]["new"] == 0.0055
    assert {"machine", "outcome", "dry_run", "plan_sha256", "components"} <= doc.keys()
    assert {"register", "axis", "before", "change", "written", "read_back", "unit"} <= rows[("G54", "Z")].keys()
    (attempt,) = attempts(db)
    assert attempt.outcome == "dry_run" and attempt.plan_sha256 == doc["plan_sha256"]
    assert [c.outcome for c in attempt.components] == ["planned"] * 4


def test_applied_writes_at_the_increment_and_reads_back(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    import hashlib

    link = write_link(tmp_path, control, machine="mc-07")
    plan = make_plan(capsys, tmp_path, link)
    db = tmp_path / "h.db"
    code, doc, err = write(capsys, link, plan, db, "--apply", "--operator", "anna")
    assert code == 0, err
    assert doc["outcome"] == "applied" and doc["machine"] == "mc-07"
    assert doc["plan_sha256"] == hashlib.sha256(plan.read_bytes()).hexdigest()
    for path, change in CHANGES.items():
        assert control.values[path] == pytest.approx(VALUES[path] + change, abs=1e-9)
    for c in doc["components"]:
        assert c["written"] == c["read_back"] and abs(c["written"] - (c["before"] + c["change"])) < 1e-9
    (attempt,) = attempts(db)
    assert (attempt.outcome, attempt.machine, attempt.operator) == ("applied", "mc-07", "anna")
    assert {(c.register, c.outcome) for c in attempt.components} == {
        ("G54", "confirmed"),
        ("G55", "confirmed"),
        ("H5", "confirmed"),
        ("H12", "confirmed"),
    }
    g54 = next(c for c in attempt.components if c.register == "G54")
    assert (g54.before, g54.written, g54.read_back) == (-412.53, -412.553, -412.553)


def test_a_table_changed_since_the_plan_is_refused(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    link = write_link(tmp_path, control)
    plan = make_plan(capsys, tmp_path, link)
    control.edit("H5", -0.02)  # the setter edits H5 wear at the panel
    db = tmp_path / "h.db"
    code, doc, err = write(capsys, link, plan, db, "--apply")
    assert code == 6 and doc["outcome"] == "refused" and "changed since the plan" in err and "H5" in err
    assert control.writes == [] and control.values["G54.Z"] == -412.53
    assert attempts(db)[0].outcome == "refused"


def test_the_interlock_refuses(capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl) -> None:
    link = write_link(tmp_path, control)
    plan = make_plan(capsys, tmp_path, link)
    control.running = True
    db = tmp_path / "h.db"
    code, doc, err = write(capsys, link, plan, db, "--apply")
    assert code == 6 and doc["outcome"] == "refused" and "interlock" in err
    assert control.writes == [] and attempts(db)[0].outcome == "refused"


def test_writes_ignored_while_a_program_runs_are_caught_by_the_read_back(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    """A link file without its interlock node: the control ignores the writes; the read-back sees it."""
    link = write_link(tmp_path, control, interlock=None)
    plan = make_plan(capsys, tmp_path, link)
    control.running = True
    db = tmp_path / "h.db"
    code, doc, err = write(capsys, link, plan, db, "--apply")
    assert code == 7 and doc["outcome"] == "rolled_back" and "read back differs" in err
    assert control.values["G54.Z"] == -412.53
    (attempt,) = attempts(db)
    assert attempt.outcome == "rolled_back" and {c.outcome for c in attempt.components} == {"rolled_back"}
    g54 = next(c for c in attempt.components if c.register == "G54")
    assert (g54.written, g54.read_back, g54.restored) == (-412.553, -412.53, -412.53)


def test_a_limit_refuses(capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl) -> None:
    link = write_link(tmp_path, control)
    plan = make_plan(capsys, tmp_path, link)
    doc = json.loads(plan.read_text())
    doc["corrections"]["W1"] = 0.5  # the model's register limit is 0.1
    plan.write_text(json.dumps(doc))
    db = tmp_path / "h.db"
    code, out, err = write(capsys, link, plan, db, "--apply")
    assert code == 6 and out["outcome"] == "refused" and "G54.Z: change 0.5 beyond the register's limit 0.1" in err
    assert control.writes == [] and attempts(db)[0].outcome == "refused"


def test_a_wear_clamped_by_the_control_is_rolled_back(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    link = write_link(tmp_path, control)
    plan = make_plan(capsys, tmp_path, link)
    control.spec.clamp["H5"] = (-0.015, 0.015)  # the control holds H5 wear within ±0.015: −0.021 becomes −0.015
    db = tmp_path / "h.db"
    code, doc, err = write(capsys, link, plan, db, "--apply")
    assert code == 7 and doc["outcome"] == "rolled_back"
    assert "H5 written -0.021 read back -0.015" in err
    assert control.values == {**control.values, **{k: pytest.approx(v) for k, v in VALUES.items()}}
    (attempt,) = attempts(db)
    h5 = next(c for c in attempt.components if c.register == "H5")
    assert (h5.written, h5.read_back, h5.restored, h5.outcome) == (-0.021, -0.015, -0.012, "rolled_back")


def test_a_read_only_node_is_denied_and_the_others_rolled_back(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    link = write_link(tmp_path, control, {**MAP, "H12": {"length": "RO.H12"}})
    plan = make_plan(capsys, tmp_path, link)
    db = tmp_path / "h.db"
    code, doc, err = write(capsys, link, plan, db, "--apply")
    assert code == 7 and doc["outcome"] == "rolled_back" and "BadUserAccessDenied" in err
    assert control.values["G54.Z"] == -412.53 and control.values["RO.H12"] == 0.0035
    assert ("G54.Z", -412.553) in control.writes  # written, then put back
    assert attempts(db)[0].outcome == "rolled_back"


def test_an_inch_control_gets_inch_values_at_its_increment(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    inch = {reg: {axis: f"IN.{path}" for axis, path in comps.items()} for reg, comps in MAP.items()}
    link = write_link(tmp_path, control, inch, unit="inch", increment=0.0001)
    plan = make_plan(capsys, tmp_path, link)
    assert json.loads(plan.read_text())["corrections"] == {"W1": -0.023, "W2": 0.022, "T5": -0.009, "T12": 0.002}
    db = tmp_path / "h.db"
    code, doc, err = write(capsys, link, plan, db, "--apply")
    assert code == 0, err
    for path, change in CHANGES.items():
        before = round(VALUES[path] / 25.4, 4)
        expected = (
            math.floor((before + change / 25.4) / 0.0001 + 0.5) * 0.0001
            if before + change / 25.4 >= 0
            else -math.floor(-(before + change / 25.4) / 0.0001 + 0.5) * 0.0001
        )
        assert control.values[f"IN.{path}"] == pytest.approx(expected, abs=1e-9)
    assert {c["unit"] for c in doc["components"]} == {"inch"}


def test_connection_lost_mid_write_and_the_control_back_is_rolled_back(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    link = write_link(tmp_path, control, timeout=2.0)
    plan = make_plan(capsys, tmp_path, link)
    control.stop_after(1, restart=True)  # the first write lands, then the server goes and comes back
    db = tmp_path / "h.db"
    from setupfix.links import open_link
    from setupfix.model import load_model
    from setupfix.usecases.machine import Retry, load_plan, write_to_control

    model = load_model(MODEL)
    with open_store(db) as store, open_link(link) as opened:
        result = write_to_control(model, load_plan(plan, model), opened, apply=True, store=store, retry=Retry(20, 1.0))
    assert result.outcome == "rolled_back" and result.exit_status == 7 and "connection lost" in result.message
    assert control.values["G54.Z"] == -412.53 and control.writes[0] == ("G54.Z", -412.553)
    assert attempts(db)[0].outcome == "rolled_back"


def test_server_stopped_between_two_writes_says_check_the_control(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    link = write_link(tmp_path, control, timeout=3.0)
    plan = make_plan(capsys, tmp_path, link)
    control.stop_after(1)  # the first write lands, then the control is gone for good
    db = tmp_path / "h.db"
    code, doc, err = write(capsys, link, plan, db, "--apply")
    assert code == 7 and doc["outcome"] == "unconfirmed" and "CHECK THE CONTROL" in err
    assert "G54.Z before -412.53 written -412.553" in err  # every component's state is named
    assert control.values["G55.Z"] == -412.487  # the write that was cut (its answer may or may not have come)
    assert control.values["G54.Z"] == -412.553  # what the control really holds now
    (attempt,) = attempts(db)
    assert attempt.outcome == "unconfirmed" and {c.outcome for c in attempt.components} == {"unknown"}


def test_an_unreachable_control_is_exit_8_and_recorded(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = tmp_path / "link.toml"
    path.write_text(
        f'[link]\nprotocol = "opcua"\nendpoint = "opc.tcp://127.0.0.1:{free_port()}"\ntimeout = 1.0\n'
        '[registers."G54"]\nZ = "ns=2;s=G54.Z"\n[registers."G55"]\nZ = "ns=2;s=G55.Z"\n'
        '[registers."H5"]\nlength = "ns=2;s=H5"\n[registers."H12"]\nlength = "ns=2;s=H12"\n'
    )
    plan = tmp_path / "plan.json"
    doc = {
        "verdict": "apply",
        "solved": True,
        "corrections": {"W1": 0.001, "W2": 0.0, "T5": 0.0, "T12": 0.0},
        "link": {
            "name": "x",
            "unit": "mm",
            "increment": 0.0001,
            "current": [{"register": "G54", "axis": "Z", "value": 1.0}],
        },
    }
    plan.write_text(json.dumps(doc))
    db = tmp_path / "h.db"
    code, out, err = write(capsys, str(path), plan, db, "--apply")
    assert code == 8 and out["outcome"] == "unreachable" and "could not be reached" in err
    assert attempts(db)[0].outcome == "unreachable"
    code, _, err = run(capsys, "machine", "write", "--link", str(path), "--model", MODEL, "--db", str(db), REPORT)
    assert code == 8 and "cannot reach the control" in err
    assert [a.outcome for a in attempts(db)] == ["unreachable", "unreachable"]  # a report's write too
    code, _, err = run(capsys, "machine", "read", "--link", str(path))
    assert code == 8 and "cannot reach the control" in err
    code, _, err = run(capsys, "correct", "--model", MODEL, "--link", str(path), REPORT)
    assert code == 8 and "cannot reach the control" in err


def test_a_plan_that_is_not_apply_is_never_written(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    link = write_link(tmp_path, control)
    plan = make_plan(capsys, tmp_path, link)
    db = tmp_path / "h.db"
    for verdict, solved in (("hold", True), ("reject", True), ("apply", False)):
        doc = json.loads(plan.read_text())
        doc["verdict"], doc["solved"] = verdict, solved
        plan.write_text(json.dumps(doc))
        code, got, err = write(capsys, link, plan, db, "--apply")
        assert code == 6 and got["outcome"] == "refused" and "nothing is written" in err
    doc["verdict"], doc["solved"] = "apply", True
    plan.write_text(json.dumps(doc))
    draft = tmp_path / "draft.toml"
    draft.write_text(Path(MODEL).read_text().replace("[process]\n", "[process]\ndraft = true\n", 1))
    code, _, err = run(
        capsys,
        "machine",
        "write",
        "--link",
        link,
        "--model",
        str(draft),
        "--plan",
        str(plan),
        "--apply",
        "--db",
        str(db),
    )
    assert code == 6 and "the model is a draft" in err and control.writes == []
    assert [a.outcome for a in attempts(db)] == ["refused"] * 4


def test_write_from_a_report_corrects_and_writes(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, control: TestControl
) -> None:
    link = write_link(tmp_path, control)
    code, out, err = run(capsys, "machine", "write", "--link", link, "--model", MODEL, "--apply", REPORT)
    assert code == 0, err
    assert "applied" in out and control.values["G54.Z"] == -412.553


def test_an_applied_write_and_a_refusal_are_audited_on_postgresql(
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    control: TestControl,
    pg_url: str,  # noqa: F811 - the fixture
) -> None:
    link = write_link(tmp_path, control, machine="mc-07")
    plan = make_plan(capsys, tmp_path, link)
    argv = ["machine", "write", "--link", link, "--model", MODEL, "--plan", str(plan), "--db", pg_url, "--apply"]
    code, _, err = run(capsys, *argv, "--operator", "anna")
    assert code == 0, err
    code, _, err = run(capsys, *argv)  # the table is not what the plan was made with any more
    assert code == 6 and "changed since the plan" in err
    with open_store(pg_url, machine="mc-07") as store:
        applied, refused = store.link_attempts()
    assert (applied.outcome, applied.operator, refused.outcome) == ("applied", "anna", "refused")
    first = applied.components[0]
    assert (first.register, first.before, first.written, first.read_back) == (
        "G54",
        -412.53,
        -412.553,
        -412.553,
    )
    assert pg_url.split("@")[0].split(":")[-1] not in applied.link + applied.message
