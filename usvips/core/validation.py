"""Checks of user-supplied parameters that raise :class:`InvalidParameterError` naming the parameter."""

from __future__ import annotations

import math
import unicodedata

import numpy as np

from usvips.core.errors import InvalidParameterError


def finite(name: str, value: float) -> float:
    """Return ``value`` as a float, or raise if it is not a finite number."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(name, f"{value!r} is not a number") from None
    if not math.isfinite(number):
        raise InvalidParameterError(name, f"must be finite, got {number}")
    return number


def positive(name: str, value: float) -> float:
    """Return ``value`` as a float, or raise if it is not finite and strictly positive."""
    number = finite(name, value)
    if number <= 0.0:
        raise InvalidParameterError(name, f"must be > 0, got {number:g}")
    return number


def finite_vector(name: str, value, size: int) -> np.ndarray:
    """Return ``value`` as a float64 vector of ``size`` finite elements, or raise."""
    try:
        vector = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidParameterError(name, f"{value!r} is not a vector of numbers") from None
    if vector.size != size:
        raise InvalidParameterError(name, f"must have {size} elements, got {vector.size}")
    if not np.all(np.isfinite(vector)):
        raise InvalidParameterError(name, "must be finite")
    return vector


def finite_array(name: str, value, last_dim: int) -> np.ndarray:
    """Return ``value`` as a float64 array of shape ``(N, last_dim)`` (a single row is promoted)."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidParameterError(name, "is not an array of numbers") from None
    if array.ndim == 1:
        array = array.reshape(1, -1)
    if array.ndim != 2 or array.shape[1] != last_dim:
        raise InvalidParameterError(name, f"must have shape (N, {last_dim}), got {array.shape}")
    if not np.all(np.isfinite(array)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(array), axis=1))[0])
        raise InvalidParameterError(name, f"row {bad} is not finite")
    return array


#: the longest name (a label, a period, a prefix) taken, in characters
MAX_NAME_LENGTH = 200


#: formatting characters that hide or reorder text (bidirectional overrides and isolates, zero-width space,
#: byte-order mark, soft hyphen); the joiners some scripts need (U+200C, U+200D) are allowed
_INVISIBLE = frozenset("\u00ad\u200b\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2060\u2066\u2067\u2068\u2069"
                       "\ufeff\ufff9\ufffa\ufffb")


def printable(parameter: str, text: str) -> str:
    """``text``, or raise if it holds control or invisible formatting characters (a tab, NUL, an escape, a
    line separator, a right-to-left override …): they corrupt tables, CSV files and terminals."""
    text = str(text)
    bad = next((c for c in text if unicodedata.category(c) in ("Cc", "Cs", "Zl", "Zp") or c in _INVISIBLE), None)
    if bad is not None:
        shown = text.encode("unicode_escape").decode("ascii")[:80]
        raise InvalidParameterError(parameter, f"'{shown}' holds a control character (U+{ord(bad):04X}); use "
                                    "printable characters")
    return text


def name(parameter: str, text: str, allow_empty: bool = False) -> str:
    """``text`` stripped, or raise if it is not :func:`printable`, is empty (unless ``allow_empty``) or is
    longer than :data:`MAX_NAME_LENGTH`."""
    text = printable(parameter, text).strip()
    if not text and not allow_empty:
        raise InvalidParameterError(parameter, "must not be empty")
    if len(text) > MAX_NAME_LENGTH:
        raise InvalidParameterError(parameter, f"is {len(text)} characters long; at most {MAX_NAME_LENGTH}")
    return text


def folder_name(parameter: str, text: str) -> str:
    """:func:`name`, also refused when it could not be one folder's or file's name: a slash or a backslash
    in it, or a leading '.' (a hidden name, or '..' out of its folder). Pair labels are such names: a pair
    taken from a video is written under ``frames/LABEL``."""
    text = name(parameter, text)
    if "/" in text or "\\" in text or text.startswith("."):
        raise InvalidParameterError(parameter, f"{text!r}: give a name without slashes that does not start with '.'")
    return text


def count(parameter: str, value, low: int, high: int) -> int:
    """``value`` as a whole number from ``low`` to ``high``, or raise naming ``parameter`` (a count of 10⁸
    is refused here, by name, rather than by the memory it would take)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(parameter, f"{value!r} is not a whole number") from None
    if not math.isfinite(number) or number != int(number):
        raise InvalidParameterError(parameter, f"{value!r} is not a whole number")
    if not low <= int(number) <= high:
        raise InvalidParameterError(parameter, f"must be from {low} to {high}, got {int(number)}")
    return int(number)
