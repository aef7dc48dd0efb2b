"""A PostgreSQL database per test, on the server ``SETUPFIX_TEST_PG`` names (``.ci/postgres`` starts one).

Without that variable a test that needs the server is skipped with the reason -- except
under CI (``CI=true``), where a missing server is a failure: the store suite must run on
both back ends there.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Iterator
from pathlib import Path

import pytest

ENV = "SETUPFIX_TEST_PG"
BACKENDS = ("sqlite", "postgres")


def server_url() -> str:
    """The test server's URL (a database on it that tests may create others from)."""
    url = os.environ.get(ENV, "")
    if not url:
        reason = f"no PostgreSQL test server: {ENV} is not set (.ci/postgres starts a throw-away one)"
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(reason + " -- under CI the store tests must run on PostgreSQL too")
        pytest.skip(reason)
    try:
        import psycopg  # noqa: F401
    except ImportError:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail("psycopg is not installed (the 'plant' extra, part of 'test')")
        pytest.skip("psycopg is not installed (pip install -e '.[plant]')")
    return url


def _on(url: str, database: str) -> str:
    base, _, rest = url.rpartition("/")
    query = "?" + rest.split("?", 1)[1] if "?" in rest else ""
    return f"{base}/{database}{query}"


@pytest.fixture
def pg_url() -> Iterator[str]:
    """The URL of a new, empty database, dropped after the test."""
    import psycopg

    url = server_url()
    name = f"t_{secrets.token_hex(6)}"
    with psycopg.connect(url, autocommit=True) as admin:
        admin.execute(f"CREATE DATABASE {name}")
    try:
        yield _on(url, name)
    finally:
        with psycopg.connect(url, autocommit=True) as admin:
            admin.execute(f"DROP DATABASE IF EXISTS {name} WITH (FORCE)")


@pytest.fixture(params=BACKENDS)
def location(request: pytest.FixtureRequest, tmp_path: Path) -> str:
    """A new store's location on each back end: a file, or a new PostgreSQL database."""
    if request.param == "sqlite":
        return str(tmp_path / "h.db")
    return str(request.getfixturevalue("pg_url"))
