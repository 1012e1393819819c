"""Words the window shows about counts and kinds, free of Qt: ``1 pair`` / ``2 pairs``, ``an arc`` /
``a length``."""

from __future__ import annotations

#: nouns whose plural is not noun + "s"
IRREGULAR = {"vertex": "vertices", "vertices": "vertices"}


def plural(count: int, noun: str) -> str:
    """``1 pair``, ``2 pairs``, ``1 vertex``, ``3 vertices``, ``0 pairs``."""
    if count == 1:
        return f"{count} {'vertex' if noun == 'vertices' else noun}"
    return f"{count} {IRREGULAR.get(noun, noun + 's')}"


def article(word: str) -> str:
    """``an arc``, ``an object``, ``a length``, ``a point`` (by the first letter: the kinds' names)."""
    return f"{'an' if word[:1].lower() in 'aeiou' else 'a'} {word}"


def species_text(record) -> str:
    """An observation record's species as shown: ``Gadus morhua``, ``Gadus morhua × 3``; '' without a
    record or a species."""
    if record is None or not record.name:
        return ""
    return record.name + (f" × {record.number}" if record.number != 1 else "")
