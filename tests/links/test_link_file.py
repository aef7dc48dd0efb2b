"""The link file, the model's components, the control's grid and units, the plan file, the audit's schema:
everything of the machine link that needs no control."""

from __future__ import annotations

import json
import random
import sqlite3
from decimal import ROUND_HALF_UP, Decimal
from pathlib import Path

import pytest
from conftest import SAMPLES
from pgserver import location, pg_url  # noqa: F401 - fixtures

from setupfix.cli import exit_codes
from setupfix.core.errors import ParseError, SetupfixError
from setupfix.links import Component, LinkConfigError, load_link, open_link
from setupfix.links.errors import EXIT_REFUSED, EXIT_UNCONFIRMED, EXIT_UNREACHABLE, LinkRefused, LinkUnreachable
from setupfix.links.mapping import model_components, round_to_increment, to_control, to_model
from setupfix.links.snapshot import ControlSnapshot
from setupfix.model import load_model
from setupfix.store import open_store
from setupfix.store.link_audit import LinkAttempt, LinkComponentRecord
from setupfix.store.postgres import MIGRATIONS as PG_MIGRATIONS
from setupfix.store.schema import SCHEMA_VERSION, migrate
from setupfix.usecases.machine import load_plan

MODEL = SAMPLES / "controllers" / "model.toml"
XYZ = SAMPLES / "two_station_xyz" / "model.toml"
GOOD = """[link]
protocol = "opcua"
endpoint = "opc.tcp://10.0.0.7:4840"
unit = "inch"
increment = 0.0001
user = "setter"
password_env = "H1_PW"
interlock = "ns=2;s=/Channel/State/progRunning"
machine = "mc-07"
[registers."G54"]
X = "ns=2;s=/Channel/Offsets/G54/X"
z = "nsu=urn:acme:cnc;s=/G54/Z"
[registers."H5"]
length = "ns=3;i=1042"
"""


def write(tmp_path: Path, text: str) -> str:
    path = tmp_path / "mc07.toml"
    path.write_text(text)
    return str(path)


def test_a_link_file_loads_and_hides_its_password(tmp_path: Path) -> None:
    config = load_link(write(tmp_path, GOOD), environ={"H1_PW": "s3cret-value"})
    assert (config.protocol, config.unit, config.increment, config.machine) == ("opcua", "inch", 0.0001, "mc-07")
    assert config.node_map == {
        Component("G54", "X"): "ns=2;s=/Channel/Offsets/G54/X",
        Component("G54", "Z"): "nsu=urn:acme:cnc;s=/G54/Z",
        Component("H5", "length"): "ns=3;i=1042",
    }
    assert config.password == "s3cret-value"
    assert "s3cret-value" not in repr(config) and "s3cret-value" not in config.name


@pytest.mark.parametrize(
    ("edit", "where", "what"),
    [
        (("[link]\n", "[lnk]\n"), "[lnk]", "unknown table"),
        (('protocol = "opcua"', 'protocol = "focas"'), "[link.protocol]", "unknown protocol 'focas'"),
        (('unit = "inch"', 'unit = "cm"'), "[link.unit]", "expected mm or inch"),
        (("increment = 0.0001", "increment = -1"), "[link.increment]", "expected a number > 0"),
        (("increment = 0.0001", "increment = 5"), "[link.increment]", "no control's"),
        (('machine = "mc-07"', 'machine = "mc-07"\nspeed = 3'), "[link.speed]", "unknown key"),
        (('X = "ns=2;s=/Channel/Offsets/G54/X"', 'X = "G54/X"'), "[registers.G54.X]", "not an OPC UA node id"),
        (('X = "ns=2;s=/Channel/Offsets/G54/X"', 'Q = "ns=2;s=a"'), "[registers.G54.Q]", "unknown component"),
        (('length = "ns=3;i=1042"', 'length = "ns=3;i=1042"\nX = "ns=3;i=1"'), "[registers.H5]", "not both"),
        (('interlock = "ns=2;s=/Channel/State/progRunning"', 'interlock = "running"'), "[link.interlock]", "node id"),
        (('endpoint = "opc.tcp://10.0.0.7:4840"', 'endpoint = "http://x"'), "[link.endpoint]", "opc.tcp://"),
        (('user = "setter"\n', ""), "[link.password_env]", "password_env without user"),
        (('machine = "mc-07"', 'security = "Basic256Sha256,Encrypt,c.pem,k.pem"'), "[link.security]", "mode"),
        (('machine = "mc-07"', 'security = "Basic256Sha256,SignAndEncrypt,c.pem,k.pem"'), "[link.security]", "no such"),
        (("[link]\n", "[link\n"), "mc07.toml", "not a valid TOML file"),
    ],
)
def test_a_bad_link_file_names_file_and_key(tmp_path: Path, edit: tuple[str, str], where: str, what: str) -> None:
    assert edit[0] in GOOD
    path = write(tmp_path, GOOD.replace(*edit))
    with pytest.raises(LinkConfigError) as caught:
        load_link(path, environ={"H1_PW": "x"})
    assert str(caught.value).startswith(path) and where in str(caught.value) and what in str(caught.value)


def test_a_missing_password_variable_is_named_not_guessed(tmp_path: Path) -> None:
    with pytest.raises(LinkConfigError, match=r"\[link.password_env\]: the environment variable H1_PW is not set"):
        load_link(write(tmp_path, GOOD), environ={})


def test_the_model_components_one_axis_and_multi_axis() -> None:
    assert model_components(load_model(MODEL)) == {
        "W1": Component("G54", "Z"),
        "W2": Component("G55", "Z"),
        "T5": Component("H5", "length"),
        "T12": Component("H12", "length"),
    }
    xyz = model_components(load_model(XYZ))
    assert xyz["W1.C"] == Component("G54", "C") and xyz["T1.R"] == Component("D1", "radius")
    assert xyz["T1"] == Component("H1", "length") and len(xyz) == 11


def test_round_to_increment_is_the_nearest_multiple() -> None:
    rng = random.Random(7)
    for _ in range(2000):
        increment = rng.choice((0.001, 0.0001, 0.005, 0.01, 0.0005))
        value = rng.uniform(-1000.0, 1000.0)
        expected = float((Decimal(repr(value)) / Decimal(repr(increment))).quantize(Decimal(1), ROUND_HALF_UP))
        assert round_to_increment(value, increment) == pytest.approx(expected * increment, abs=1e-9)
    assert round_to_increment(-412.5194, 0.001) == -412.519 and round_to_increment(-0.0005, 0.001) == -0.001
    assert repr(round_to_increment(-412.53 + 0.011, 0.001)) == "-412.519"


def test_units_convert_lengths_and_leave_rotations() -> None:
    x, c = Component("G54", "X"), Component("G54", "C")
    assert to_control(25.4, x, "mm", "inch") == pytest.approx(1.0) and to_model(1.0, x, "mm", "inch") == 25.4
    assert to_control(0.5, c, "mm", "inch") == 0.5 and to_model(0.5, c, "mm", "inch") == 0.5


def test_exit_statuses_are_the_specs() -> None:
    assert (EXIT_REFUSED, EXIT_UNCONFIRMED, EXIT_UNREACHABLE) == (6, 7, 8)
    assert (exit_codes.REFUSED, exit_codes.UNCONFIRMED, exit_codes.UNREACHABLE) == (6, 7, 8)
    assert LinkRefused("x").exit_status == 6 and LinkUnreachable("x").exit_status == 8
    assert LinkConfigError("x").exit_status == 1 and isinstance(LinkConfigError("x"), SetupfixError)


def test_a_snapshot_round_trips_and_a_bad_one_is_named(tmp_path: Path) -> None:
    snap = ControlSnapshot.of("c", "mm", 0.001, {Component("G54", "X"): -412.53, Component("H5", "length"): 0.1})
    from setupfix.core.errors import SourceLocation

    assert ControlSnapshot.from_json(json.loads(json.dumps(snap.to_json())), SourceLocation("p.json")) == snap
    bad = snap.to_json() | {"current": [{"register": "G54", "axis": "W", "value": 1.0}]}
    with pytest.raises(ParseError, match=r"p.json: \[link.current\[0\]\]: unknown axis 'W'"):
        ControlSnapshot.from_json(bad, SourceLocation("p.json"))


def plan_doc(**extra: object) -> dict[str, object]:
    link = {"name": "c", "unit": "mm", "increment": 0.001, "current": [{"register": "G54", "axis": "Z", "value": 1.0}]}
    return {"verdict": "apply", "corrections": {"W1": 0.01, "W2": 0.0, "T5": 0.0, "T12": 0.0}, "link": link} | extra


@pytest.mark.parametrize(
    ("doc", "what"),
    [
        ({k: v for k, v in plan_doc().items() if k != "link"}, "records no values read from the control"),
        (plan_doc(corrections={"W1": 0.01}), "no correction for T12, T5, W2"),
        (plan_doc(corrections={"W1": 0.01, "W2": 0, "T5": 0, "T12": 0, "W9": 1}), "register 'W9' is not"),
        (plan_doc(verdict="maybe"), "expected a verdict"),
        ({"parts": [plan_doc(), plan_doc()]}, "the plan holds 2 parts"),
    ],
)
def test_a_plan_without_what_a_write_needs_is_refused(tmp_path: Path, doc: dict[str, object], what: str) -> None:
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ParseError, match=what):
        load_plan(path, load_model(MODEL))


def test_a_plan_file_gives_its_hash_and_values(tmp_path: Path) -> None:
    import hashlib

    path = tmp_path / "plan.json"
    path.write_text(json.dumps({"parts": [plan_doc()]}))
    plan = load_plan(path, load_model(MODEL))
    assert plan.sha256 == hashlib.sha256(path.read_bytes()).hexdigest() and plan.refusal is None
    assert dict(plan.corrections)["W1"] == 0.01 and plan.made_with is not None


ATTEMPT = LinkAttempt(
    link="opc.tcp://x (l.toml)",
    plan_sha256="a" * 64,
    outcome="rolled_back",
    message="not confirmed",
    unit="mm",
    components=(
        LinkComponentRecord("G54", "Z", -412.53, -0.023, -412.553, -412.53, -412.53, "rolled_back"),
        LinkComponentRecord("H5", "length", -0.012, -0.009, -0.021, None, None, "unknown"),
    ),
)


def test_a_v5_store_gets_the_link_audit_on_both_back_ends(location: str) -> None:  # noqa: F811 - the fixture
    """Schema 6: an older store is migrated (its rows kept) and then records attempts like a new one."""
    if location.startswith("postgresql"):
        import psycopg

        with psycopg.connect(location, autocommit=True) as con:
            con.execute("CREATE TABLE schema_version (version INTEGER NOT NULL)")
            con.execute("INSERT INTO schema_version VALUES (5)")
            for script in PG_MIGRATIONS[:5]:
                for statement in script.split(";"):
                    if statement.strip():
                        con.execute(statement)
            con.execute("INSERT INTO temperature (timestamp, channel, value) VALUES ('t', 'c', 1.5)")
    else:
        db = sqlite3.connect(location, isolation_level=None)
        migrate(db, location, upto=5)
        db.execute("INSERT INTO temperature (timestamp, channel, value) VALUES ('t', 'c', 1.5)")
        db.close()
    with open_store(location, machine="mc-07", operator="anna") as store:
        assert store.count("temperature") == 1 and store.link_attempts() == []
        store.add_link_attempt(ATTEMPT)
    with open_store(location, machine="other") as store:
        assert store.link_attempts() == []
        (got,) = store.link_attempts(every_machine=True)
    assert got.components == ATTEMPT.components and (got.machine, got.operator) == ("mc-07", "anna")
    assert (got.outcome, got.plan_sha256, got.link) == ("rolled_back", "a" * 64, ATTEMPT.link) and got.created_at
    assert SCHEMA_VERSION == 6 and len(PG_MIGRATIONS) == 6


def test_an_unmapped_component_is_named_before_anything_is_read(tmp_path: Path) -> None:
    pytest.importorskip("asyncua")
    from setupfix.usecases.machine import read_control

    path = write(tmp_path, GOOD.replace('password_env = "H1_PW"\n', "").replace('user = "setter"\n', ""))
    with open_link(path) as link, pytest.raises(LinkConfigError) as caught:
        read_control(link, load_model(MODEL))  # the model's G54.Z is mapped; G55, H12 are not (nor X: not the model's)
    assert str(caught.value).startswith(f"{path}: [registers]: not mapped to a node: G55.Z, H12")


@pytest.mark.parametrize("unit", ["mm", "inch"])
def test_the_current_csv_of_a_read_round_trips_through_the_one_reader(tmp_path: Path, unit: str) -> None:
    """Multi-axis: X, Y, Z and the rotation C of each WKS, tool lengths and a radius; an inch control's
    lengths come out in the model's mm (rotations stay in degrees)."""
    from parsers.current import read_current
    from setupfix.usecases.machine import ControlRead, write_current_csv

    model = load_model(XYZ)
    comps = model_components(model)
    rng = random.Random(3)
    step = 0.0001 if unit == "inch" else 0.001
    values = {
        c: round_to_increment(rng.uniform(-300, 300) if not c.rotation else rng.uniform(-1, 1), step)
        for c in comps.values()
    }
    read = ControlRead(ControlSnapshot.of("c", unit, step, values))
    path = tmp_path / "current.csv"
    write_current_csv(read, model, path)
    got = read_current(path, model)
    assert got.keys() == comps.keys()
    for rid, comp in comps.items():
        assert got[rid] == pytest.approx(to_model(values[comp], comp, "mm", unit), abs=1e-9)
    assert "G54,C," in path.read_text() and "H1,," in path.read_text() and "D1,," in path.read_text()
