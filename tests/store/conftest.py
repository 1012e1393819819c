"""A real PostgreSQL server for the store's tests: one per test session (the ``pgserver`` wheel starts
PostgreSQL 16 in a temporary folder in a few seconds, as any user including root), and a fresh database
per test. Nothing is skipped for want of a server: when it cannot start, the tests that need it fail."""

from __future__ import annotations

import itertools
import os
import shutil
import tempfile
from pathlib import Path
from urllib.parse import urlsplit, urlunsplit

import psycopg
import pytest

_names = itertools.count()
PASSWORD_USER, PASSWORD = "annotator", "s3cret-Pw"


@pytest.fixture(scope="session")
def postgres_server():
    """The URL of the session's server (its maintenance database ``postgres``)."""
    folder = tempfile.mkdtemp(prefix="usvips-pg-")
    os.environ.setdefault("XDG_RUNTIME_DIR", folder)  # pgserver asks for one; a container may have none
    import pgserver

    server = pgserver.get_server(Path(folder) / "data", cleanup_mode="delete")
    try:
        with psycopg.connect(server.get_uri(), autocommit=True) as connection:
            # a throw-away server: no waiting for the disk (a session's many small databases otherwise
            # cost a minute of flushing at shutdown on a slow, shared disk)
            for setting in ("fsync", "synchronous_commit", "full_page_writes"):
                connection.execute(f"ALTER SYSTEM SET {setting} = off")
            # an annotator who must give a password (the rest of the server trusts local users)
            connection.execute(f"CREATE ROLE {PASSWORD_USER} LOGIN CREATEDB PASSWORD '{PASSWORD}'")
            hba = Path(server.pgdata) / "pg_hba.conf"
            hba.write_text(f"local all {PASSWORD_USER} scram-sha-256\n" + hba.read_text())
            connection.execute("SELECT pg_reload_conf()")
        yield server.get_uri()
    finally:
        server.cleanup()
        shutil.rmtree(folder, ignore_errors=True)


def database_url(server_url: str, name: str) -> str:
    """The URL of the database ``name`` on the server of ``server_url``."""
    parts = urlsplit(server_url)
    return urlunsplit((parts.scheme, parts.netloc, f"/{name}", parts.query, ""))


@pytest.fixture
def new_database(postgres_server):
    """A function giving the URL of a new database name on the session's server (created on first use)."""
    def make(stem: str = "survey") -> str:
        return database_url(postgres_server, f"{stem}_{next(_names)}")
    return make
