"""A form's fields by the parameters errors name (:mod:`usvips.gui.field_errors`): a form declares one
:class:`FormFields` (parameter → its widget and label) beside its widgets; :meth:`FormFields.show` puts an
error to the user in the form's terms, with the field at fault outlined and given the keyboard, so that
the window names its own field instead of the library's setting."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import shiboken6
from PySide6 import QtWidgets

from usvips.core.errors import UsvipsError
from usvips.gui.field_errors import FieldError, field_error

#: how a field at fault is outlined (until it is edited, or the form is checked again)
MARK_STYLE = "border: 2px solid #c0392b;"
#: the widget property that says a field is marked (tests and style sheets read it)
MARKED = "fieldError"


def _edited_signal(widget: QtWidgets.QWidget):
    """The signal a widget sends when the user changes it (None for a widget without one)."""
    if isinstance(widget, QtWidgets.QLineEdit):
        return widget.textEdited
    if isinstance(widget, QtWidgets.QSpinBox | QtWidgets.QDoubleSpinBox):
        return widget.valueChanged
    if isinstance(widget, QtWidgets.QComboBox):
        return widget.currentIndexChanged
    if isinstance(widget, QtWidgets.QAbstractButton):
        return widget.toggled
    return None


class FormFields:
    """``fields``: parameter → (widget, label) of one form; ``say(text)`` shows a message under the form.
    ``fields`` may be a callable returning the mapping, for forms whose fields are rebuilt (a housing kind's
    values)."""

    def __init__(self, fields: Mapping[str, tuple[QtWidgets.QWidget, str]]
                 | Callable[[], Mapping[str, tuple[QtWidgets.QWidget, str]]], say: Callable[[str], None]) -> None:
        self._fields = fields
        self.say = say
        self._marked: dict[QtWidgets.QWidget, tuple[str, str]] = {}  # widget → (its own style, parameter)

    @property
    def fields(self) -> Mapping[str, tuple[QtWidgets.QWidget, str]]:
        return self._fields() if callable(self._fields) else self._fields

    def show(self, error: UsvipsError, where: str = "") -> FieldError | None:
        """Say ``error``: in the form's terms with its field marked and focused when its parameter names one
        of the form's fields (returned), else as it is (None). A mark left by an earlier error is cleared."""
        self.clear()
        fields = self.fields
        found = field_error(error, {name: label for name, (_, label) in fields.items()}, where)
        if found is None:
            self.say(f"{where}{error}")
            return None
        self.mark(fields[found.parameter][0], found.parameter)
        self.say(found.text)
        return found

    def mark(self, widget: QtWidgets.QWidget, parameter: str) -> None:
        """Outline ``widget`` (the field of ``parameter``) and give it the keyboard (its text selected) until
        the user changes it."""
        self._marked[widget] = (widget.styleSheet(), parameter)
        widget.setProperty(MARKED, True)
        widget.setStyleSheet(MARK_STYLE)
        widget.setFocus()
        if isinstance(widget, QtWidgets.QLineEdit):
            widget.selectAll()
        signal = _edited_signal(widget)
        if signal is not None:
            def edited(*_args, widget=widget) -> None:
                signal.disconnect(edited)
                self._unmark(widget)
            signal.connect(edited)

    def clear(self) -> None:
        """No field marked."""
        for widget in list(self._marked):
            self._unmark(widget)

    def _unmark(self, widget: QtWidgets.QWidget) -> None:
        if widget in self._marked:
            style, _ = self._marked.pop(widget)
            if not shiboken6.isValid(widget):  # a field the form has since rebuilt
                return
            widget.setProperty(MARKED, False)
            widget.setStyleSheet(style)

    def marked(self) -> list[str]:
        """The parameters whose fields are marked now."""
        return [parameter for _, parameter in self._marked.values()]


__all__ = ["MARKED", "MARK_STYLE", "FormFields"]
