"""``usvips project push FILE URL`` / ``usvips project pull URL FILE``: copy a whole project between an
SQLite project file and a survey on a PostgreSQL server, row by row (ids, numbers and stamps as stored).

A push makes a new survey (a database that does not exist yet, or an empty one); a pull makes a new
file. Either is all or nothing, and the source is never changed. Messages name the server without the
password."""

from __future__ import annotations

import argparse
from pathlib import Path

from usvips.core.errors import InvalidParameterError

# the project store (numpy, SciPy, OpenCV) is imported by the handlers only: ``usvips project --help``
# registers these actions without it


def register_sync_actions(actions: argparse._SubParsersAction) -> None:
    push = actions.add_parser("push", help="copy a project file to a new survey on a PostgreSQL server")
    push.add_argument("file", help="the project file (.usvips)")
    push.add_argument("url", help="postgresql://USER[:PASSWORD]@HOST[:PORT]/DATABASE (a new or empty database)")
    push.set_defaults(handler=run_push)
    pull = actions.add_parser("pull", help="copy a survey on a PostgreSQL server to a new project file")
    pull.add_argument("url", help="postgresql://USER[:PASSWORD]@HOST[:PORT]/DATABASE")
    pull.add_argument("file", help="the new project file (.usvips; must not exist)")
    pull.set_defaults(handler=run_pull)


def _locations(args: argparse.Namespace) -> tuple[Path, str]:
    from usvips.store.location import is_server_location

    if not is_server_location(args.url):
        raise InvalidParameterError("URL", "give the survey's server as postgresql://USER@HOST[:PORT]/DATABASE")
    if is_server_location(args.file):
        raise InvalidParameterError("FILE", "give a project file here, not a server URL")
    return Path(args.file), args.url


def run_push(args: argparse.Namespace) -> int:
    from usvips.store.transfer import push

    path, url = _locations(args)
    print(f"copied {path} to {push(path, url)}")
    return 0


def run_pull(args: argparse.Namespace) -> int:
    from usvips.store.location import public_location
    from usvips.store.transfer import pull

    path, url = _locations(args)
    print(f"copied {public_location(url)} to {pull(url, path)}")
    return 0
