"""The bench's PostgreSQL server: the one the environment names, else one started for the rows, which leaves
no folder behind (each run of the server area left an empty ``usvips-bench-pg-*`` folder in /tmp), or a
reason when there is none."""

import os
import sys
import tempfile
from urllib.parse import urlsplit, urlunsplit

from usvips.bench.postgres_server import NO_SERVER, bench_server
from usvips.store.postgres import database_command


def test_a_server_started_for_the_rows_is_stopped_and_its_folder_removed(monkeypatch, tmp_path):
    monkeypatch.delenv("USVIPS_BENCH_POSTGRES", raising=False)
    monkeypatch.delenv("XDG_RUNTIME_DIR", raising=False)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    with bench_server("usvips-bench-pg-") as (url, why_not):
        assert url is not None and url.startswith("postgresql://") and why_not == ""
        parts = urlsplit(url)
        database_command(urlunsplit((parts.scheme, parts.netloc, "/bench_check", parts.query, "")),
                         "CREATE DATABASE {}")  # the server answers
        assert len(list(tmp_path.glob("usvips-bench-pg-*"))) == 1
    assert list(tmp_path.iterdir()) == []
    assert "XDG_RUNTIME_DIR" not in os.environ


def test_the_server_the_environment_names_is_used_and_nothing_is_made(monkeypatch, tmp_path):
    monkeypatch.setenv("USVIPS_BENCH_POSTGRES", "postgresql://bench@db.example/postgres")
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    with bench_server("usvips-bench-pg-") as (url, why_not):
        assert (url, why_not) == ("postgresql://bench@db.example/postgres", "")
    assert list(tmp_path.iterdir()) == []


def test_without_a_server_the_rows_are_told_why(monkeypatch, tmp_path):
    monkeypatch.delenv("USVIPS_BENCH_POSTGRES", raising=False)
    monkeypatch.setitem(sys.modules, "pgserver", None)  # not installed
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    with bench_server("usvips-bench-pg-") as (url, why_not):
        assert url is None and why_not == NO_SERVER
    assert list(tmp_path.iterdir()) == []
