"""The error for an input path that is not a readable file: missing, a folder, or a pipe or a device (each
said as such: a folder exists, so "no such file" would send the user looking for the wrong thing)."""

from __future__ import annotations

import os
import stat
from pathlib import Path

from usvips.core.errors import InputFileError


def special_kind(path: str | Path) -> str | None:
    """What an existing path that is neither a regular file nor a folder is ("a named pipe", "a device",
    "a socket"), or None (a regular file, a folder, or nothing there). Symbolic links are followed."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    if stat.S_ISFIFO(mode):
        return "a named pipe"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return None


def not_a_file(path: str | Path, what: str = "file") -> InputFileError:
    """An :class:`InputFileError` naming ``path``: "is a folder, not a {what}", "is a named pipe (or a
    device), not a regular {what}" or "no such {what}"."""
    if Path(path).is_dir():
        return InputFileError(str(path), f"is a folder, not a {what}")
    kind = special_kind(path)
    if kind is not None:
        return InputFileError(str(path), f"is {kind}, not a regular {what}: save it to a file first")
    return InputFileError(str(path), f"no such {what}")
