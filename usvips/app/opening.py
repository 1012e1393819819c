"""Opening what the user names: a project file, a survey on a server (a ``postgresql://`` URL), or a
sample directory (``project.json`` + its files),
whose project file ``project.usvips`` is created beside its manifest on first use. The command line and
the window open projects through here.
"""

from __future__ import annotations

from pathlib import Path

from usvips.app.samples import open_or_create_from_manifest
from usvips.core.errors import InputFileError
from usvips.store.interface import ProjectStore
from usvips.store.location import is_server_location
from usvips.store.opening import open_project as open_store


def open_project(path: str | Path, read_only: bool = False) -> ProjectStore:
    """The project at ``path``: a project file or a server URL (``read_only``: never written, never
    migrated), or a sample directory's project (created from its manifest the first time; never
    read-only). Anything else is an :class:`InputFileError` naming the path."""
    if is_server_location(path):
        return open_store(path, read_only=read_only)
    path = Path(path)
    if path.is_dir():
        if read_only:
            sample = path / "project.usvips"
            if not sample.is_file():
                raise InputFileError(str(path), "a sample directory without its project file yet: open it for "
                                     "writing once to create it")
            return open_store(sample, read_only=True)
        return open_or_create_from_manifest(path)
    if path.is_file():
        return open_store(path, read_only=read_only)
    raise InputFileError(str(path), "no such project file or sample directory")
