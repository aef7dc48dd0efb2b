"""Issue 37 item 15, first bullet: anything that looks like a URL is read as one, and no message shows its
password or a piece of it.

The issue's cases were ``PostgreSQL://…``, ``postgresql:/…`` and a leading space, each taken for a file path
whose name (password included) was printed.  The property here runs many passwords holding ``@ : / # % ? &``
(typed without percent-encoding) through every mistyping of the scheme, against a port nothing listens on:
each is one :class:`StoreError` (cannot reach the server, or not a URL setupfix can read) whose text holds
neither the password nor any piece of it between those characters.
"""

from __future__ import annotations

import re
import string
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from setupfix.cli import main
from setupfix.core.errors import StoreError
from setupfix.inputs.stores import StoreRef
from setupfix.store import is_server, open_store, shown_location
from setupfix.store.urls import parse_url

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "sample_reports" / "guide_pins"
SPECIAL = "@:/#%?&"
#: How a URL's beginning gets mistyped (the last two are well formed).
SCHEMES = (
    "PostgreSQL://",
    "POSTGRES://",
    " postgresql://",
    "postgresql:/",
    "postgresql:",
    "postgres:/",
    "Postgres:///",
    "\tpostgresql:// ",
    "postgresql://",
    "postgres://",
)

passwords = st.text(alphabet=string.ascii_letters + string.digits + SPECIAL, min_size=6, max_size=24).filter(
    lambda p: any(c in SPECIAL for c in p) and any(len(f) >= 4 for f in re.split(r"[@:/#%?&]", p))
)


def pieces(password: str) -> list[str]:
    """The password and its pieces between special characters (four characters or more: a shorter one may be
    a piece of the host or the database name)."""
    return [password, *(f for f in re.split(r"[@:/#%?&]", password) if len(f) >= 4)]


def message(exc: StoreError) -> str:
    return " ".join(str(x) for x in (exc, exc.hint, exc.location) if x)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(password=passwords, scheme=st.sampled_from(SCHEMES), pad=st.sampled_from(("", " ", "  \t")))
def test_no_piece_of_a_password_is_ever_shown(password: str, scheme: str, pad: str) -> None:
    url = f"{pad}{scheme}setupfix:{password}@127.0.0.1:1/setupfix_test{pad}"
    assert is_server(url)
    with pytest.raises(StoreError) as caught:
        open_store(url).close()
    text = message(caught.value)
    assert "cannot reach the database server" in text or "not a PostgreSQL URL" in text, text
    assert "127.0.0.1" in text and "setupfix" in text
    for shown in (text, shown_location(url), str(StoreRef(url))):
        leaked = [p for p in pieces(password) if p in shown]
        assert leaked == [], (shown, leaked)


@settings(max_examples=100, deadline=None)
@given(password=passwords)
def test_a_well_formed_url_keeps_its_whole_password(password: str) -> None:
    """The password is all between the user's ':' and the last '@': never split into host or database."""
    got = parse_url(f"  PostgreSQL://ana:{password}@db.plant:6543/shop  ")
    assert (got.user, got.host, got.port, got.dbname) == ("ana", "db.plant", "6543", "shop")
    if "%" not in password:
        assert got.password == password
    assert got.shown == "postgresql://ana@db.plant:6543/shop"


@pytest.mark.parametrize(
    "location",
    [
        "PostgreSQL://setupfix:Zq9@x/Yv8#w%Kp?@127.0.0.1:1/shop",
        " postgresql://setupfix:Zq9@x/Yv8#w%Kp?@127.0.0.1:1/shop",
        "postgresql:/setupfix:Zq9@x/Yv8#w%Kp?@127.0.0.1:1/shop",
        "postgres:setupfix:Zq9@x/Yv8#w%Kp?@127.0.0.1:1/shop ",
    ],
)
def test_every_door_refuses_a_mistyped_url_in_one_line_without_the_password(
    location: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    for argv in (
        ["history", "show", "--db", location],
        ["history", "import", "--db", location, str(GUIDE / "cycle_01.csv")],
        ["batch", str(GUIDE), "--model", str(GUIDE / "model.toml"), "--out", "-", "--store", location],
        ["correct", str(GUIDE / "cycle_01.csv"), "--model", str(GUIDE / "model.toml"), "--store", location],
    ):
        capsys.readouterr()
        assert main(argv) != 0, argv
        out, err = capsys.readouterr()
        lines = [x for x in err.splitlines() if x.startswith("error:")]
        assert len(lines) == 1 and "127.0.0.1" in lines[0], (argv, err)
        assert "Traceback" not in err and "internal error" not in err
        for piece in ("Zq9", "Yv8", "Kp?", "x/Y"):
            assert piece not in out + err, (argv, out, err)
    assert list(tmp_path.iterdir()) == []  # never a file of that name
