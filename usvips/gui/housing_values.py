"""Housing values a user types in a calibration wizard (Qt-free): each water housing kind's parameters with
their unit and meaning, and a typed value read as fixed (``0.016``) or a prior (``1.34 ± 0.01``). The
classic wizard and the target path's pages both ask here."""

from __future__ import annotations

import math

from usvips.core import housing as housings
from usvips.core.errors import InvalidParameterError, UsvipsError

#: kind → symbol → (unit, meaning), from the housing registry
HOUSING_PARAMETERS = {name: {s.symbol: (s.unit, s.meaning) for s in housings.kind(name).specs}
                      for name in housings.water_names()}


def parse_known(text: str) -> tuple[float, float | None] | None:
    """``"0.016"`` → fixed at 0.016; ``"1.34 ± 0.01"`` (or ``+-``) → a prior; blank → None (default)."""
    text = text.strip().replace("+-", "±").replace("+/-", "±")
    if not text:
        return None
    value, _, sigma = text.partition("±")
    try:
        return float(value), (float(sigma) if sigma.strip() else None)
    except ValueError:
        raise UsvipsError(f"{text!r}: type a value (fixed) or 'value ± sigma' (a prior)") from None


def known_label(housing: str, symbol: str) -> str:
    """How the wizards' forms name the field of ``symbol`` of ``housing``: "housing value t (m)"."""
    unit, _ = HOUSING_PARAMETERS.get(housing, {}).get(symbol, ("", ""))
    return f"housing value {symbol} ({unit})" if unit not in ("", "—") else f"housing value {symbol} (no unit)"


def read_known(housing: str, texts: dict[str, str]) -> dict[str, tuple[float, float | None]]:
    """The housing values typed (symbol → text; blank texts left out) → symbol → (value, σ or None to hold
    it fixed). A value that is not a number, a σ that is not positive, or a value outside the parameter's
    physical range (the kind's declared bounds, e.g. a thickness > 0 m) is an
    :class:`InvalidParameterError` naming the symbol (so the form names its field)."""
    kind = housings.kind(housing)
    known = {}
    for symbol, text in texts.items():
        try:
            parsed = parse_known(text)
        except UsvipsError as error:
            raise InvalidParameterError(symbol, str(error)) from None
        if parsed is None:
            continue
        value, sigma = parsed
        spec = kind.spec(symbol)
        if not math.isfinite(value):
            raise InvalidParameterError(symbol, f"must be a finite number, got {value!r}")
        if sigma is not None and not (math.isfinite(sigma) and sigma > 0):
            raise InvalidParameterError(symbol, f"its sigma must be a positive number, got {sigma!r}")
        if spec.lower is not None and not value > spec.lower:
            raise InvalidParameterError(symbol, f"must be > {spec.lower:g} {spec.unit}, got {value:g} ({spec.meaning})")
        if spec.upper is not None and not value < spec.upper:
            raise InvalidParameterError(symbol, f"must be < {spec.upper:g} {spec.unit}, got {value:g} ({spec.meaning})")
        known[symbol] = (value, sigma)
    return known
