"""Parameters several housing kinds share (the media's refractive indices)."""

from __future__ import annotations

from usvips.core import validation
from usvips.core.housing.parameter import HousingParameter

#: Water: fresh ≈ 1.333, sea ≈ 1.34 (temperature, salinity and wavelength move the third decimal).
N3 = HousingParameter("n3", "—", "refractive index of the water (fresh ≈ 1.333, sea ≈ 1.34)", 1.34, 0.01,
                      1.0, None)


def index(name: str, value: float) -> float:
    """A refractive index: finite and positive (the calibration's bounds keep glass and water above 1)."""
    return validation.positive(name, value)


def check_indices(housing: object) -> None:
    """Validate n1, n2, n3 of a housing dataclass in place (a non-positive index names itself)."""
    for name in ("n1", "n2", "n3"):
        object.__setattr__(housing, name, index(name, getattr(housing, name)))


def finite(housing: object, names: tuple[str, ...]) -> None:
    for name in names:
        object.__setattr__(housing, name, validation.finite(name, getattr(housing, name)))


def positive(housing: object, names: tuple[str, ...]) -> None:
    for name in names:
        object.__setattr__(housing, name, validation.positive(name, getattr(housing, name)))
