"""The housing-kind registry: every kind of housing is one :class:`~usvips.core.housing.base.Housing`
subclass in one module of ``usvips.core.housing.kinds``; defining the class (with a ``kind`` name)
registers it, and the registry imports every module of that package the first time it is asked
(nothing lists the kinds by hand). The calibration, the calibration file, scenes, manifests, the command
line and the wizard ask the registry; an unknown kind is an error naming the known ones.

A new kind: write ``kinds/<name>.py`` with the class (its surfaces, ``specs``, ``calibration_names``,
validity in the constructor; :meth:`Housing.build` when its calibration's names are not simply the
fields per camera or shared) and its test; nothing else.
"""

from __future__ import annotations

from usvips.core.errors import InvalidParameterError
from usvips.core.housing.base import KINDS as _TABLE
from usvips.core.housing.base import Housing

_KINDS = _TABLE.kinds


class UnknownHousingError(InvalidParameterError):
    """A housing kind the registry does not know."""

    def __init__(self, name: object, known: tuple[str, ...] | None = None):
        super().__init__("housing", f"unknown housing kind {name!r}; known: {', '.join(known or names())}")


def names() -> tuple[str, ...]:
    """Every registered kind, in the order the kinds ask for (``order``), then by name."""
    return _TABLE.names()


def registered_kinds() -> tuple[type[Housing], ...]:
    return _TABLE.classes()


def water_names() -> tuple[str, ...]:
    """The kinds a phase-2 (underwater) calibration estimates: those with parameters (not air)."""
    return tuple(n for n in names() if _KINDS[n].calibration_names)


def kind(name: str, among: tuple[str, ...] | None = None) -> type[Housing]:
    """The kind called ``name`` (optionally only among ``among``); anything else is an
    :class:`UnknownHousingError` listing the known kinds."""
    _TABLE.discover()
    if not isinstance(name, str) or name not in _KINDS or (among is not None and name not in among):
        raise UnknownHousingError(name, among)
    return _KINDS[name]
