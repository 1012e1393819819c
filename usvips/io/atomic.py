"""Writing files so that an error never leaves a partial one behind.

Every output path is checked first (:func:`check_output_path`): it must not be a folder, its folder must
exist and be writable, its name must not be too long. The data then go to a temporary file in the same
folder, which is renamed into place only when complete; on any error the temporary file is removed and
the old file (if any) is untouched. Failures are :class:`OutputFileError` naming the path.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from usvips.core.errors import InputFileError

#: The longest file name (one path component, in bytes) most file systems accept.
NAME_MAX = 255


class OutputFileError(InputFileError):
    """A file we were asked to write cannot be written; the message names the path and the reason."""


def check_output_path(path: str | Path) -> Path:
    """``path`` as a :class:`Path` if a file can be written there; else :class:`OutputFileError`."""
    path = Path(path)
    if not str(path) or path.name in ("", ".", ".."):
        raise OutputFileError(str(path), "not a file name")
    if len(os.fsencode(path.name)) > NAME_MAX:
        raise OutputFileError(f"{str(path)[:60]}…", f"the file name is too long ({len(os.fsencode(path.name))} "
                              f"bytes; at most {NAME_MAX})")
    if path.is_dir():
        raise OutputFileError(str(path), "is a folder; give a file name")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise OutputFileError(str(path), f"the folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputFileError(str(path), f"the folder {folder} is not writable")
    if path.exists() and not os.access(path, os.W_OK):
        raise OutputFileError(str(path), "the file is read-only")
    return path


def write_bytes_atomic(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder, then rename it into place."""
    path = check_output_path(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        handle, temporary = tempfile.mkstemp(prefix=".usvips.", suffix=".tmp", dir=str(folder))
    except OSError as error:
        raise OutputFileError(str(path), f"cannot write: {error.strerror or error}") from None
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temporary, 0o666 & ~umask)  # mkstemp makes 0600; give the file a normal file's mode
        os.replace(temporary, path)
    except OSError as error:
        Path(temporary).unlink(missing_ok=True)
        raise OutputFileError(str(path), f"cannot write: {error.strerror or error}") from None
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8, newlines as given) to ``path`` atomically (see :func:`write_bytes_atomic`)."""
    write_bytes_atomic(path, text.encode("utf-8"))


def write_files_atomic(files: dict[Path, str]) -> None:
    """Write a set of text files all or nothing: every text goes to a temporary file beside its target
    first; only when all are written are they renamed into place, and if a rename fails the targets
    already replaced get their old contents back (or are removed when they did not exist)."""
    temporaries: dict[Path, str] = {}
    backups: dict[Path, str | None] = {}
    try:
        for path, text in files.items():
            path = check_output_path(path)
            folder = path.parent if str(path.parent) else Path(".")
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
