"""Numbers as people and other programs write them: ASCII digits, a sign, a decimal point, an exponent.

Python's ``float`` and ``int`` also read digit separators (``1_000``) and other scripts' digits (``١٢``).
A spreadsheet, R or another tool reads such a field as text, so a file or an option holding one is
refused like text rather than read as a number no one else would see. (No NumPy here: the command line
reads its options with it before NumPy is imported.)
"""

from __future__ import annotations


def plain_number(text: str, kind: type = float) -> float | int:
    """``kind(text)`` (``float`` or ``int``) of a number written in ASCII without digit separators;
    :class:`ValueError` otherwise (as ``kind`` raises it for text)."""
    if "_" in text or not text.isascii():
        raise ValueError(text)
    return kind(text)
