"""The housing values a user knows, as a form in a calibration wizard: one field per parameter of the
housing kind — blank (the default shown), a value (held fixed) or 'value ± sigma' (weighted; read by
:func:`usvips.gui.housing_values.parse_known`). The classic wizard and the target path's phase-2 page both
fill their form here."""

from __future__ import annotations

from PySide6 import QtWidgets

from usvips.core.calibration.phases import DEFAULT_HOUSING
from usvips.gui.housing_values import HOUSING_PARAMETERS


def fill_known_form(form: QtWidgets.QFormLayout, housing: str,
                    known: dict[str, tuple[float, float | None]]) -> dict[str, QtWidgets.QLineEdit]:
    """Replace ``form``'s rows by one field per parameter of ``housing``, filled with the ``known`` values
    (symbol → (value, sigma or None)); returns the fields by symbol."""
    while form.rowCount():
        form.removeRow(0)
    fields = {}
    for name, (value, sigma) in DEFAULT_HOUSING[housing].items():
        unit, meaning = HOUSING_PARAMETERS.get(housing, {}).get(name, ("", ""))
        edit = QtWidgets.QLineEdit()
        edit.setMinimumWidth(200)  # "default 0.05 ± 0.001" shows whole
        edit.setMaximumWidth(200)
        edit.setPlaceholderText("default " + f"{value:g}" + (f" ± {sigma:g}" if sigma else " (fixed)"))
        edit.setToolTip(f"{name}: {meaning} ({unit})")
        if name in known:
            known_value, known_sigma = known[name]
            edit.setText(f"{known_value:g}" + (f" ± {known_sigma:g}" if known_sigma else ""))
        explanation = QtWidgets.QLabel(meaning)
        explanation.setStyleSheet("color: #666;")
        row = QtWidgets.QHBoxLayout()
        row.addWidget(edit)
        row.addWidget(explanation, 1)
        form.addRow(f"{name} ({unit})" if unit not in ("", "—") else f"{name} (no unit)", row)
        fields[name] = edit
    return fields
