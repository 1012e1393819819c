"""The last page of both calibration wizards (the classic one and the target path): name the calibration
(its session's default name, its σ0 and the time), the pairs it becomes active for, its report (PDF); Finish
stores it in the project and fires the wizard's ``saved(calibration_id)``. One page for both, handed the
session (``default_name()``, ``result``, ``project``, ``phase``, ``save(name, active_for)``) and its report
button (:class:`usvips.gui.qt.exchange_dialogs.WizardReport` or a kind of it)."""

from __future__ import annotations

import datetime

from PySide6 import QtWidgets

from usvips.core.errors import UsvipsError
from usvips.gui.qt import active_pairs

ERROR_STYLE = "color: #c0392b;"


class SavePage(QtWidgets.QWizardPage):
    """``report``: the page's Report (PDF)… button and status (made with the page as its parent, by
    ``make_report(page)``); ``subtitle``: what Finish and Cancel do."""

    def __init__(self, session, make_report, subtitle: str) -> None:
        super().__init__()
        self.session = session
        self.setTitle("Save the calibration")
        self.setSubTitle(subtitle)
        self.name = QtWidgets.QLineEdit()
        self.active = QtWidgets.QListWidget()
        self.message = QtWidgets.QLabel()
        self.message.setWordWrap(True)
        self.message.setStyleSheet(ERROR_STYLE)
        self.report = make_report(self)
        report_row = QtWidgets.QHBoxLayout()
        report_row.addWidget(self.report.button)
        report_row.addWidget(self.report.status, 1)
        form = QtWidgets.QFormLayout(self)
        name_label = QtWidgets.QLabel("&Name")
        name_label.setBuddy(self.name)
        active_label = QtWidgets.QLabel("&Active for")
        active_label.setBuddy(self.active)
        form.addRow(name_label, self.name)
        form.addRow(active_label, self.active)
        form.addRow("Report", report_row)
        form.addRow(self.message)
        self.saved_id: int | None = None

    def initializePage(self) -> None:  # noqa: N802 (Qt's name)
        stamp = datetime.datetime.now().strftime("%Y-%m-%d %H:%M")
        sigma = self.session.result.calibration.sigma0_px
        self.name.setText(f"{self.session.default_name()} σ0 {sigma:.3f} px {stamp}")
        medium = "air" if self.session.phase == "air" else "water"
        self.message.setText("" if active_pairs.fill(self.active, self.session.project, medium) else
                             f"the project has no {medium} pairs yet: the calibration is stored, active for none; "
                             "choose it for a pair later")

    def active_for(self) -> list[str]:
        return active_pairs.ticked(self.active)

    def validatePage(self) -> bool:  # noqa: N802 (Qt's name)
        try:
            self.saved_id = self.session.save(self.name.text(), self.active_for())
        except UsvipsError as error:
            self.message.setText(str(error))
            return False
        self.wizard().saved.emit(self.saved_id)
        return True


__all__ = ["SavePage"]
