"""Checks of user-supplied parameters that raise :class:`InvalidParameterError` naming the parameter."""

from __future__ import annotations

import math

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
