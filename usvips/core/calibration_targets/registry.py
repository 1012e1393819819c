"""The calibration-target registry: one :class:`~usvips.core.calibration_targets.base.CalibrationTarget`
subclass per module of ``usvips.core.calibration_targets.kinds``, imported the first time a kind is asked
for. An unknown kind is an error naming the known ones."""

from __future__ import annotations

from usvips.core.calibration_targets.base import KINDS as _TABLE
from usvips.core.calibration_targets.base import CalibrationTarget
from usvips.core.errors import InvalidParameterError


def names() -> tuple[str, ...]:
    """Every registered target kind, in menu order."""
    return _TABLE.names()


def kind(name: str) -> type[CalibrationTarget]:
    """The class of target kind ``name``."""
    _TABLE.discover()
    if name not in _TABLE.kinds:
        raise InvalidParameterError("target", f"unknown target kind {name!r}; known: {', '.join(names())}")
    return _TABLE.kinds[name]


def from_description(description: dict, source: str = "") -> CalibrationTarget:
    """A target from its description (a dict with ``"kind"``); errors name ``source``."""
    if not isinstance(description, dict) or not isinstance(description.get("kind"), str):
        where = f"{source}: " if source else ""
        raise InvalidParameterError("target", f"{where}a target description needs a \"kind\" (one of "
                                    f"{', '.join(names())})")
    return kind(description["kind"]).from_description(description, source)
