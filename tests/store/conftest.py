"""The store tests' back ends: ``location`` (a file, and a database on the test PostgreSQL server) and ``pg_url``."""

from pgserver import location, pg_url

__all__ = ["location", "pg_url"]
