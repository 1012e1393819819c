"""One opener by location: a file path is an SQLite project file, a ``postgresql://`` (or
``postgres://``) URL a survey on a PostgreSQL server. Code that opens or creates a project calls
:func:`open_project` / :func:`create_project` and gets a :class:`~usvips.store.interface.ProjectStore`;
it never names an implementation. A new backend is one module and one branch here.
"""

from __future__ import annotations

from pathlib import Path
from urllib.parse import parse_qsl, urlencode, urlsplit, urlunsplit

from usvips.store.interface import ProjectStore

SERVER_SCHEMES = ("postgresql://", "postgres://")
OWN_QUERY = ("media", "cache")  # URL query parameters USVIPS reads itself (not passed to the server)


def is_server_location(location: str | Path) -> bool:
    """True when ``location`` names a survey on a server (a ``postgresql://`` URL), not a file."""
    return isinstance(location, str) and location.startswith(SERVER_SCHEMES)


def public_location(url: str) -> str:
    """A server URL without its password (nor USVIPS's own query parameters): what messages show."""
    parts = urlsplit(url)
    host = parts.hostname or ""
    if parts.port:
        host = f"{host}:{parts.port}"
    user = f"{parts.username}@" if parts.username else ""
    query = [(k, v) for k, v in parse_qsl(parts.query) if k not in OWN_QUERY and k != "password"]
    return urlunsplit((parts.scheme, user + host, parts.path, urlencode(query), ""))


def without_password(url: str) -> str:
    """A server URL as it may be kept (a recent-projects list): its password left out, all else kept (a
    password then comes from the server's usual sources, e.g. ``~/.pgpass``)."""
    parts = urlsplit(url)
    netloc = parts.netloc.rsplit("@", 1)
    if len(netloc) == 2:
        netloc[0] = netloc[0].split(":", 1)[0]
    query = [(k, v) for k, v in parse_qsl(parts.query) if k != "password"]
    return urlunsplit((parts.scheme, "@".join(netloc), parts.path, urlencode(query), ""))


def database_name(url: str) -> str:
    """The name of the database a server URL names (its path); empty when it names none."""
    return urlsplit(url).path.strip("/")


def shown(location: str | Path) -> str:
    """How a location is printed: a file as its path, a server URL without its password."""
    return public_location(location) if is_server_location(location) else str(location)


def open_project(location: str | Path, read_only: bool = False) -> ProjectStore:
    """The existing project at ``location`` (``read_only``: every write refused, nothing migrated)."""
    if is_server_location(location):
        from usvips.store.postgres import ServerProject  # psycopg is needed only for a server

        return ServerProject.open(str(location), read_only=read_only)
    from usvips.store.project import Project

    return Project.open(location, read_only=read_only)


def create_project(location: str | Path) -> ProjectStore:
    """A new, empty project at ``location`` (a file that must not exist yet, or an empty database on a
    server); open for writing."""
    if is_server_location(location):
        from usvips.store.postgres import ServerProject

        return ServerProject.create(str(location))
    from usvips.store.project import Project

    return Project.create(location)
