"""Housing values a user types in a calibration wizard (Qt-free): each water housing kind's parameters with
their unit and meaning, and a typed value read as fixed (``0.016``) or a prior (``1.34 ± 0.01``). The
classic wizard and the target path's pages both ask here."""

from __future__ import annotations

from usvips.core import housing as housings
from usvips.core.errors import UsvipsError

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
