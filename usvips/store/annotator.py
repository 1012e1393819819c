"""Who is annotating: the name every new or changed object, vertex and observation record is stamped
with, and every history row carries.

Set once per session: ``$USVIPS_ANNOTATOR``, else the operating system's user name; the command line's
``--annotator NAME`` (on the commands that write) overrides both for one command (:func:`annotating_as`).
A store reads :func:`current_annotator` when it is opened (its ``annotator`` attribute, which a caller may
also set).
"""

from __future__ import annotations

import getpass
import os
from collections.abc import Iterator
from contextlib import contextmanager

from usvips.core.errors import UsvipsError

ANNOTATOR_ENVIRONMENT = "USVIPS_ANNOTATOR"
MAX_NAME_LENGTH = 200
_override: list[str] = []


def checked_annotator(name: str, where: str = "--annotator") -> str:
    """``name`` stripped, when it is a usable annotator's name: not empty, one line, at most
    :data:`MAX_NAME_LENGTH` characters, no control characters; else a ``UsvipsError`` naming ``where``."""
    stripped = str(name).strip()
    if not stripped:
        raise UsvipsError(f"{where}: the annotator's name is empty; give a name (e.g. your initials)")
    if len(stripped) > MAX_NAME_LENGTH:
        raise UsvipsError(f"{where}: the annotator's name is {len(stripped)} characters long; at most "
                          f"{MAX_NAME_LENGTH} please")
    if any(ord(c) < 32 or ord(c) == 127 for c in stripped):
        raise UsvipsError(f"{where}: the annotator's name {stripped!r} holds a control character (a line break, "
                          "a tab, …); give it on one line")
    return stripped


def current_annotator() -> str:
    """The annotator now: the innermost :func:`annotating_as`, else ``$USVIPS_ANNOTATOR`` (checked), else
    the operating system's user name (``"unknown"`` when it has none)."""
    if _override:
        return _override[-1]
    named = os.environ.get(ANNOTATOR_ENVIRONMENT)
    if named is not None:
        return checked_annotator(named, f"${ANNOTATOR_ENVIRONMENT}")
    try:
        return checked_annotator(getpass.getuser(), "the operating system's user name")
    except (OSError, KeyError, ImportError, UsvipsError):
        return "unknown"


@contextmanager
def annotating_as(name: str | None) -> Iterator[None]:
    """Within this context, stores opened take ``name`` (checked) as their annotator; None changes nothing."""
    if name is None:
        yield
        return
    _override.append(checked_annotator(name))
    try:
        yield
    finally:
        _override.pop()
