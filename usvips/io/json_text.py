"""JSON text read strictly: a key given twice in one object is an error naming the key (``json.loads`` keeps
the last one without a word, so an edited file's first value would be silently dropped)."""

from __future__ import annotations

import json
from pathlib import Path

from usvips.core.errors import InputFileError


class _DuplicateKey(ValueError):
    def __init__(self, key: str) -> None:
        super().__init__(key)
        self.key = key


def _object(pairs: list[tuple[str, object]]) -> dict:
    out: dict = {}
    for key, value in pairs:
        if key in out:
            raise _DuplicateKey(key)
        out[key] = value
    return out


def loads_strict(text: str, path: str | Path) -> object:
    """``json.loads(text)``, a key given twice in one object an :class:`InputFileError` naming ``path`` and the
    key (a :class:`json.JSONDecodeError` passes through for the caller to word)."""
    try:
        return json.loads(text, object_pairs_hook=_object)
    except _DuplicateKey as error:
        raise InputFileError(str(path), f"the key {error.key!r} is given twice in one object (which is meant?)"
                             ) from None
