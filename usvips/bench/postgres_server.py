"""The PostgreSQL server of the bench's server rows: the one ``$USVIPS_BENCH_POSTGRES`` names (a
``postgresql://`` URL of a server where databases may be created), else a temporary one started with
``pgserver`` (the test extra) in a temporary folder, which is removed with its data when the rows are done."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

#: why there is no server when neither is at hand
NO_SERVER = "no server: set USVIPS_BENCH_POSTGRES or pip install pgserver"


@contextmanager
def bench_server(prefix: str) -> Iterator[tuple[str | None, str]]:
    """(URL of the server's maintenance database, "") while the block runs, or (None, why there is none).
    A server started here (in a folder named ``prefix…``) is stopped, and its folder removed, at the end;
    ``XDG_RUNTIME_DIR``, which pgserver asks for, is set to that folder only for the block when unset."""
    given = os.environ.get("USVIPS_BENCH_POSTGRES")
    if given:
        yield given, ""
        return
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    runtime_was_set = "XDG_RUNTIME_DIR" in os.environ
    os.environ.setdefault("XDG_RUNTIME_DIR", str(folder))  # (before the import: pgserver reads it then)
    try:
        try:
            import pgserver
        except ImportError:
            yield None, NO_SERVER
            return
        server = pgserver.get_server(folder / "data", cleanup_mode="delete")
        try:
            yield server.get_uri(), ""
        finally:
            server.cleanup()
    finally:
        if not runtime_was_set:
            os.environ.pop("XDG_RUNTIME_DIR", None)
        shutil.rmtree(folder, ignore_errors=True)
