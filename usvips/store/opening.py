"""One opener by location: a file path is an SQLite project file, a ``postgresql://`` (or
``postgres://``) URL a survey on a PostgreSQL server. Code that opens or creates a project calls
:func:`open_project` / :func:`create_project` and gets a :class:`~usvips.store.interface.ProjectStore`;
it never names an implementation. A new backend is one module and one branch here.
"""

from __future__ import annotations

from pathlib import Path

from usvips.store.interface import ProjectStore
from usvips.store.location import is_server_location


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
