"""One parameter of a housing kind: what a kind declares of each of its parameters (used by
:mod:`usvips.core.housing.base` and every kind module; listed by the registry)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class HousingParameter:
    """One parameter of a housing kind, by its symbol (``t``, ``dx``; camera frame, metres).

    ``unit`` (``m``, or ``—`` for none) and ``meaning`` are shown to the user; ``start`` is the
    calibration's default start value and ``sigma`` its default prior sigma (None: held fixed unless the
    user frees it); ``lower``/``upper`` bound the physical range (open interval; None: unbounded); ``step``
    is the numerical-derivative step.
    """

    symbol: str
    unit: str
    meaning: str
    start: float
    sigma: float | None
    lower: float | None = None
    upper: float | None = None
    step: float = 1e-6
