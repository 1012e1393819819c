"""An error named in a form's own terms (free of Qt): a form declares which of its fields each parameter an
error can carry (:attr:`usvips.core.errors.UsvipsError.parameter`, set by :func:`usvips.core.errors.concerning`
or an :class:`~usvips.core.errors.InvalidParameterError`) stands for, with the field's label as the form shows
it; :func:`field_error` then words the error with that label ("Latitude (°, WGS 84): must be between -90 and 90
…") instead of the library's name for the setting. The window marks and focuses the field
(:mod:`usvips.gui.qt.field_errors`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from usvips.core.errors import InvalidParameterError, UsvipsError


@dataclass(frozen=True)
class FieldError:
    """``parameter``: the form's key of the field at fault; ``label``: the field's label; ``text``: the
    message in the form's terms."""

    parameter: str
    label: str
    text: str


def problem_of(error: UsvipsError) -> str:
    """What is wrong, without the library's name of the setting (an :class:`InvalidParameterError`'s
    problem; any other error's whole message)."""
    return error.problem if isinstance(error, InvalidParameterError) else str(error)


def field_error(error: UsvipsError, labels: Mapping[str, str], where: str = "") -> FieldError | None:
    """``error`` worded for the field its parameter names among ``labels`` (parameter → the field's label),
    ``where`` before it ("video dive: "); None when it names none of them (the form says it as it is)."""
    parameter = getattr(error, "parameter", None)
    if parameter is None or parameter not in labels:
        return None
    label = labels[parameter].replace("&", "").rstrip(":")
    return FieldError(parameter, label, f"{where}{label}: {problem_of(error)}")


__all__ = ["FieldError", "field_error", "problem_of"]
