"""Writing files so that an error never leaves a partial one behind."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from usvips.core.errors import UsvipsError


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder, then rename it into place."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.exists():
        raise UsvipsError(f"{path}: the folder {folder} does not exist")
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", dir=str(folder))
    try:
        with os.fdopen(handle, "w", encoding="utf-8", newline="") as stream:
            stream.write(text)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temporary, 0o666 & ~umask)  # mkstemp makes 0600; give the file a normal file's mode
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


def write_files_atomic(files: dict[Path, str]) -> None:
    """Write a set of text files all or nothing: every text goes to a temporary file beside its target
    first; only when all are written are they renamed into place, and if a rename fails the targets
    already replaced get their old contents back (or are removed when they did not exist)."""
    temporaries: dict[Path, str] = {}
    backups: dict[Path, str | None] = {}
    try:
        for path, text in files.items():
            path = Path(path)
            folder = path.parent if str(path.parent) else Path(".")
            if not folder.is_dir():
                raise UsvipsError(f"{path}: the folder {folder} does not exist")
            if path.is_dir():
                raise UsvipsError(f"{path}: is a folder, not a file")
            handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", dir=str(folder))
            temporaries[path] = temporary
            with os.fdopen(handle, "w", encoding="utf-8", newline="") as stream:
                stream.write(text)
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(temporary, 0o666 & ~umask)
        for path, temporary in temporaries.items():
            if path.exists():
                handle, backup = tempfile.mkstemp(prefix=f".{path.name}.old.", dir=str(path.parent))
                os.close(handle)
                os.replace(path, backup)
                backups[path] = backup
            else:
                backups[path] = None
            os.replace(temporary, path)
    except BaseException:
        for path, backup in backups.items():
            if backup is not None:
                os.replace(backup, path)
            elif not os.path.exists(temporaries[path]) and path.exists():
                path.unlink()  # it did not exist before and was already put in place
        for temporary in temporaries.values():
            if os.path.exists(temporary):
                os.unlink(temporary)
        raise
    for backup in backups.values():
        if backup is not None and os.path.exists(backup):
            os.unlink(backup)
