"""Secrets kept (issue 34, item 4): every command-line door that takes a server location is run with a
distinctive password holding ``#``, ``@``, ``/`` and ``:`` (unencoded and percent-encoded), on the real
PostgreSQL server the suite starts; all that is printed and every file written is searched for it. The
password's other sources (``PGPASSWORD``, the password file, a service file) open a survey too; a server
address that cannot be read is one line, exit 2, nothing changed (issue 36)."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path
from urllib.parse import quote

import psycopg
import pytest

from tests.store.conftest import database_url, new_database, postgres_server  # noqa: F401 - the real server
from usvips.cli import main
from usvips.core.campaign import Campaign
from usvips.store import Project
from usvips.store.records import Vertex

SECRET_USER, SECRET = "keeper", "Zq#9@x/y:Kw!"


def run(args: list[str]) -> tuple[int, str]:
    """``usvips ARGS`` in this process: (exit status, stdout + stderr)."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        code = main(args)
    return code, out.getvalue()


def _assert_no_secret(text: str, where: str) -> None:
    for form in (SECRET, quote(SECRET, safe=""), "Zq#9", "x/y:Kw"):
        assert form not in text, f"{where} holds the password ({form!r}): {text[:300]!r}"


def _assert_no_secret_in_files(folder: Path) -> None:
    for path in folder.rglob("*"):
        if path.is_file():
            data = path.read_bytes()
            for form in (SECRET, quote(SECRET, safe="")):
                assert form.encode() not in data, f"{path} holds the password"


@pytest.fixture(scope="module")
def keeper(postgres_server):  # noqa: F811
    """A login that gives the distinctive password (over the server's socket, scram-sha-256)."""
    with psycopg.connect(postgres_server, autocommit=True) as connection:
        exists = connection.execute("SELECT 1 FROM pg_roles WHERE rolname = %s", (SECRET_USER,)).fetchone()
        if not exists:
            connection.execute(psycopg.sql.SQL("CREATE ROLE {} LOGIN CREATEDB PASSWORD {}").format(
                psycopg.sql.Identifier(SECRET_USER), psycopg.sql.Literal(SECRET)))
            data = connection.execute("SHOW data_directory").fetchone()[0]
            hba = Path(data) / "pg_hba.conf"
            hba.write_text(f"local all {SECRET_USER} scram-sha-256\n" + hba.read_text())
            connection.execute("SELECT pg_reload_conf()")
    return postgres_server


def _url(server: str, database: str, encoded: bool) -> str:
    """The survey's URL with the password written in it (unencoded or percent-encoded)."""
    socket = server.split("?host=", 1)[1]
    password = quote(SECRET, safe="") if encoded else SECRET
    return f"postgresql://{SECRET_USER}:{password}@/{database}?host={socket}"


def _project_file(folder: Path) -> Path:
    path = folder / "reef.usvips"
    with Project.create(path) as project:
        project.add_pair("p1")
        project.add_object("length", [Vertex(10.0, 20.0, 8.0, 20.0), Vertex(40.0, 20.0, 38.0, 20.0)], "snapper")
        project.set_campaign(Campaign("2024-03_reef_stereo-BRUVs"))
    return path


@pytest.mark.parametrize("encoded", [False, True], ids=["as typed", "percent-encoded"])
def test_no_command_prints_or_writes_the_password(keeper, tmp_path, encoded):
    url = _url(keeper, f"secret_{int(encoded)}", encoded)
    source = _project_file(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    doors = [
        ["project", "push", str(source), url],
        ["project", "info", url],
        ["project", "history", url],
        ["project", "history", url, "--json"],
        ["project", "review", url, "--accept", "1"],
        ["project", "review", url, "--list", "accepted"],
        ["project", "set-campaign", url, "--project", "Reef"],
        ["project", "check", url],
        ["project", "export", url, str(out / "reef.csv")],
        ["project", "pull", url, str(out / "copy.usvips")],
        ["batch", "export", url, "--out-dir", str(out / "batch"), "--jobs", "1"],
        ["project", "push", str(source), url],  # refused: the database holds a survey
    ]
    for args in doors:
        code, text = run(args)
        assert code in (0, 1, 2), f"{args[:2]}: exit {code}: {text}"
        _assert_no_secret(text, " ".join(args[:2]))
    assert (out / "copy.usvips").is_file() and (out / "reef.csv").is_file()
    _assert_no_secret_in_files(tmp_path)
    # wrong passwords and unreachable servers are said without the secret too
    for bad in (url.replace("Kw", "Kv"), url.replace("?host=", "?port=1&host=")):
        code, text = run(["project", "info", bad])
        assert code == 2 and text.count("\n") == 1
        _assert_no_secret(text, "a refused login")


def test_the_password_comes_from_pgpassword_the_password_file_or_a_service_file(keeper, tmp_path, monkeypatch):
    url = _url(keeper, "secret_sources", False)
    source = _project_file(tmp_path)
    assert run(["project", "push", str(source), url])[0] == 0
    bare = url.replace(f":{SECRET}@", "@")  # no password in the URL
    monkeypatch.setenv("PGPASSFILE", str(tmp_path / "none"))
    code, text = run(["project", "info", bare])
    assert code == 2 and "refused" in text  # no password from anywhere: refused in one line
    monkeypatch.setenv("PGPASSWORD", SECRET)
    code, text = run(["project", "info", bare])
    assert code == 0 and "1 object" in text
    monkeypatch.delenv("PGPASSWORD")
    escaped = SECRET.replace("\\", "\\\\").replace(":", "\\:")
    (tmp_path / "pgpass").write_text(f"*:*:*:{SECRET_USER}:{escaped}\n")
    (tmp_path / "pgpass").chmod(0o600)
    monkeypatch.setenv("PGPASSFILE", str(tmp_path / "pgpass"))
    code, text = run(["project", "info", bare])
    assert code == 0 and "1 object" in text
    monkeypatch.setenv("PGPASSFILE", str(tmp_path / "none"))
    socket = keeper.split("?host=", 1)[1]
    (tmp_path / "services.conf").write_text(f"[reef]\nhost={socket}\nuser={SECRET_USER}\npassword={SECRET}\n")
    monkeypatch.setenv("PGSERVICEFILE", str(tmp_path / "services.conf"))
    code, text = run(["project", "info", "postgresql:///secret_sources?service=reef"])
    assert code == 0 and "1 object" in text
    _assert_no_secret(text, "a service's survey")


BAD_ADDRESSES = {
    "a port that is not a number": ("postgresql://ann:{p}@db.example.org:54x2/reef", "the port '54x2' is not a number"),
    "a port out of range": ("postgresql://ann:{p}@db.example.org:70000/reef", "the port 70000 is out of range"),
    "a port of zero": ("postgresql://ann:{p}@db.example.org:0/reef", "the port 0 is out of range"),
    "a query port that is not a number": ("postgresql://ann@/reef?host=/tmp&port=x", "the port 'x' is not a number"),
    "an IPv6 host not closed": ("postgresql://ann:{p}@[::1:5432/reef", "has no closing ']'"),
    "an IPv6 host that is none": ("postgresql://ann:{p}@[::g]:5432/reef", "is not an IPv6 address"),
    "a stray bracket": ("postgresql://ann:{p}@db]:5432/reef", "broken IPv6 address"),
    "no database": ("postgresql://ann:{p}@db.example.org:5432/", "name the survey's database"),
}


@pytest.mark.parametrize("case", sorted(BAD_ADDRESSES))
@pytest.mark.parametrize("command", ["info", "history", "pull", "review", "push"])
def test_a_server_address_that_cannot_be_read_is_one_line_exit_2_and_nothing_changed(tmp_path, case, command):
    template, said = BAD_ADDRESSES[case]
    url = template.format(p=SECRET)
    source = _project_file(tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    args = {"info": ["project", "info", url], "history": ["project", "history", url],
            "pull": ["project", "pull", url, str(tmp_path / "copy.usvips")],
            "review": ["project", "review", url, "--accept", "1"],
            "push": ["project", "push", str(source), url]}[command]
    code, text = run(args)
    assert code == 2 and text.count("\n") == 1 and said in text, text
    assert "Traceback" not in text and "internal error" not in text
    _assert_no_secret(text, case)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


@pytest.mark.parametrize("encoded", [False, True])
def test_a_usage_error_quoting_a_server_url_hides_its_password(encoded):
    """argparse's own errors quote what was typed (an extra argument, a value not among the choices): the
    password in a server URL is not printed there either."""
    password = quote(SECRET, safe="") if encoded else SECRET
    url = f"postgresql://alice:{password}@127.0.0.1:1/survey"
    for args in (["project", "info", "x.usvips", url], ["project", "export", "m.usvips", "out", "--format", url],
                 ["project", "info", url, "--bogus-option"], [url]):
        code, text = run(args)
        assert code == 2 and text.count("\n") == 1, text
        _assert_no_secret(text, " ".join(args[:2]))
