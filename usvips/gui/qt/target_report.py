"""The target wizard's *Report (PDF)…* button: the calibration computed from target views, with the
target's points as the control and the views' detections as the observations (fitted and held-out), so
that the report holds the views, their coverage, the residuals per view and the validation."""

from __future__ import annotations

from pathlib import Path

from usvips.gui.qt.exchange_dialogs import WizardReport


class TargetReport(WizardReport):
    """:class:`WizardReport` over a :class:`~usvips.gui.target_session.TargetSession`."""

    def report_data(self):
        """The target's control points, the observations of every view kept (held-out ones included) and
        where they came from."""
        from usvips.app.target_words import target_words
        from usvips.io.calibration_report import ReportData

        session = self.session
        result = session.result
        files = [("target", session.target_source, target_words(session.target))]
        if session.source == "video":
            files.append(("video", session.video, f"the project's stereo video ({Path(session.project.path).name})"))
        else:
            files += [("images", f"{Path(left).name}, {Path(right).name}", "image pair")
                      for left, right in session.pairs]
        return ReportData(session.target.control_points(), result.observations, files)
