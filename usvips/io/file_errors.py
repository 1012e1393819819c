"""The error for an input path that is not a readable file: missing, or a folder (said as such: a folder
exists, so "no such file" would send the user looking for the wrong thing)."""

from __future__ import annotations

from pathlib import Path

from usvips.core.errors import InputFileError


def not_a_file(path: str | Path, what: str = "file") -> InputFileError:
    """An :class:`InputFileError` naming ``path``: "is a folder, not a {what}" or "no such {what}"."""
    return InputFileError(str(path), f"is a folder, not a {what}" if Path(path).is_dir() else f"no such {what}")
