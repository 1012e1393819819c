"""The "Active for" list of a calibration wizard's save page: the project's pairs of one medium, each
ticked, and the labels left ticked (the calibration wizard's and the target wizard's save pages)."""

from __future__ import annotations

from PySide6 import QtCore, QtWidgets


def fill(widget: QtWidgets.QListWidget, project, medium: str) -> int:
    """Fill ``widget`` with the project's pairs of ``medium`` ("air" or "water"), each ticked; returns how
    many there are."""
    widget.clear()
    for pair in project.pairs():
        if pair.medium != medium:
            continue
        item = QtWidgets.QListWidgetItem(pair.label)
        item.setFlags(item.flags() | QtCore.Qt.ItemFlag.ItemIsUserCheckable)
        item.setCheckState(QtCore.Qt.CheckState.Checked)
        widget.addItem(item)
    return widget.count()


def ticked(widget: QtWidgets.QListWidget) -> list[str]:
    """The labels left ticked in ``widget``."""
    return [widget.item(i).text() for i in range(widget.count())
            if widget.item(i).checkState() == QtCore.Qt.CheckState.Checked]
