"""Exchange with other tools from the window: File › Import calibration (OpenCV)…, Export calibration
(OpenCV)…, Calibration report (PDF)…, Deployment and georeference…, Calibration › Import a USVIPS
calibration… and Use a stored calibration…, and the calibration wizard's Report (PDF)… button.

Each entry asks with dialogs, then does its work through io (the command line's functions: one reader,
one writer); file names and answers can be handed in (tests, scripts), skipping the dialogs. Reports are
written by a worker off the GUI thread (:mod:`usvips.gui.qt.worker`) with a real cancel: the PDF is written
beside its target and moved into place only when the job was not cancelled.

Each entry is handed the window's context (:class:`usvips.gui.window_context.WindowContext`: the workspace,
the messages, the worker) and a parent widget for its dialogs — never the window itself.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

from usvips.app import calibration_size
from usvips.app.calibrations import read_calibration, store_calibration
from usvips.core.campaign import Campaign
from usvips.core.deployment import DEPLOYMENT_FIELDS, Deployment, Georeference
from usvips.core.errors import UsvipsError
from usvips.core.observations import StereoObservations
from usvips.core.stereo_calibration import StereoCalibration
from usvips.gui.qt.field_errors import FormFields
from usvips.gui.qt.worker import Cancelled, Worker, start
from usvips.gui.window_context import WindowContext
from usvips.io.calibration_file import load_calibration, save_calibration
from usvips.io.opencv_calibration import (
    ASSUMED_SIGMA0_PX,
    parse_image_size,
    read_opencv_stereo,
    sigma0_statement,
    write_opencv_stereo,
)

OPENCV_FILTER = "OpenCV calibrations (*.yml *.yaml *.xml *.json *.npz);;All files (*)"


# ---------------------------------------------------------------------------- reports (worker jobs)
def report_job(calibration: StereoCalibration, out: str | Path, calibration_path: str | Path | None = None,
               data=None) -> Callable:
    """A worker job writing the calibration report to ``out``: the PDF goes to a temporary file beside
    it and replaces ``out`` only when the job was not cancelled (then nothing is left behind). Returns the
    number of pages. ``data``: the report's data (:class:`usvips.io.calibration_report.ReportData`)
    when they are not files named in the calibration (the wizard's)."""
    from usvips.io.calibration_report import write_calibration_report

    out = Path(out)

    def job(progress, cancelled) -> int:
        progress(0.0)
        part = out.with_name(f".{out.stem}.part.pdf")
        try:
            pages = write_calibration_report(calibration, part, calibration_path, data=data)
            if cancelled():
                raise Cancelled()
            os.replace(part, out)
        finally:
            part.unlink(missing_ok=True)
        progress(1.0)
        return pages

    return job


def _current_calibration(context: WindowContext, parent: QtWidgets.QWidget) -> tuple[StereoCalibration, str] | None:
    """The open project's calibration for the current pair (its active one, else the newest stored), or
    one chosen from a file; with a name for messages. None when there is none or the choice was cancelled."""
    project = context.workspace.project
    if project is not None and project.calibrations():
        pair = context.workspace.pair
        chosen = project.active_calibration(pair) if pair else None
        chosen = chosen if chosen is not None else project.calibrations()[-1].id
        name = next(c.name for c in project.calibrations() if c.id == chosen)
        return read_calibration(project, chosen), name
    path, _ = QtWidgets.QFileDialog.getOpenFileName(parent, "USVIPS calibration", context.start_folder(),
                                                    "Calibrations (*.json)")
    if not path:
        return None
    return load_calibration(path), path


def _source(context: WindowContext, parent: QtWidgets.QWidget,
            source: str | Path | StereoCalibration | None) -> tuple[StereoCalibration, str] | None:
    if isinstance(source, StereoCalibration):
        return source, "calibration"
    if source is not None:
        return load_calibration(source), str(source)
    return _current_calibration(context, parent)


def _calibration_to_write(context: WindowContext, parent: QtWidgets.QWidget,
                          source: str | Path | StereoCalibration | None, out: str | Path | None, title: str,
                          name: str, file_filter: str) -> tuple[StereoCalibration, str, str | Path] | None:
    """The calibration to write out (:func:`_source`), its name for messages, and the file to write (``out``,
    else asked with a save dialog titled ``title`` offering ``name`` in the project's folder); None when
    either choice was cancelled. A calibration file that cannot be read raises :class:`UsvipsError`."""
    chosen = _source(context, parent, source)
    if chosen is None:
        return None
    if out is None:
        out, _ = QtWidgets.QFileDialog.getSaveFileName(parent, title, context.start_folder(name), file_filter)
        if not out:
            return None
    return (*chosen, out)


# ---------------------------------------------------------------------------- File menu entries
def ask_image_size(parent: QtWidgets.QWidget) -> tuple[int, int] | None:
    """Ask the image size (pixels) that an OpenCV file does not carry."""
    text, ok = QtWidgets.QInputDialog.getText(parent, "Image size", "The file does not say the image size. "
                                              "Width x height in pixels (e.g. 1920x1080):")
    if not ok:
        return None
    return parse_image_size(text.strip(), "image size")


def ask_sigma0(parent: QtWidgets.QWidget) -> float | None:
    """Ask the sigma0 (pixels) that an OpenCV file does not state; None keeps the assumed one (marked so)."""
    value, ok = QtWidgets.QInputDialog.getDouble(
        parent, "Calibration sigma0", "The file states no reprojection residual (RMS). Its sigma0 in pixels per "
        f"image coordinate, if you know it (Cancel keeps {ASSUMED_SIGMA0_PX:g} px, marked assumed in every "
        "figure made with it):", ASSUMED_SIGMA0_PX, 0.001, 100.0, 3)
    return float(value) if ok else None


def import_calibration(context: WindowContext, parent: QtWidgets.QWidget, files: list[str | Path] | None = None,
                       out: str | Path | None = None,
                       ask_size: Callable = ask_image_size, ask_sigma: Callable = ask_sigma0,
                       run: Callable[[UseCalibrationDialog], object] = lambda d: d.exec()) -> Path | None:
    """OpenCV YAML/XML (one file or intrinsics + extrinsics) or .npz → a USVIPS calibration file (and into
    the open project's calibrations, then made active where the user says, as
    :func:`import_usvips_calibration`). The image size is asked when the files lack it, and the sigma0
    when they state no residual (declined: it stays assumed, and says so)."""
    if files is None:
        files, _ = QtWidgets.QFileDialog.getOpenFileNames(parent, "OpenCV calibration (one file, or intrinsics + "
                                                          "extrinsics)", context.start_folder(), OPENCV_FILTER)
        if not files:
            return None
    try:
        calibration = read_opencv_stereo(files)
        if calibration.left.width is None:
            size = ask_size(parent)
            if size is None:
                context.messages.info("import cancelled: the image size is needed")
                return None
            calibration = read_opencv_stereo(files, size)
        if calibration.sigma0_origin == "assumed":
            sigma0 = ask_sigma(parent)
            if sigma0 is not None:
                size = (calibration.left.width, calibration.left.height) if calibration.left.width else None
                calibration = read_opencv_stereo(files, size, sigma0_px=sigma0)
        if out is None:
            start = str(Path(files[0]).with_name(Path(files[0]).stem + "_usvips.json"))
            out, _ = QtWidgets.QFileDialog.getSaveFileName(parent, "Save as a USVIPS calibration", start,
                                                           "Calibrations (*.json)")
            if not out:
                return None
        save_calibration(calibration, out)
        project = context.workspace.project
        calibration_id = None
        if project is not None:
            calibration_id = store_calibration(project, Path(out).stem, calibration)
    except UsvipsError as error:
        context.messages.error(f"import failed, nothing written: {error}")
        return None
    where = " and stored in the project" if context.workspace.project is not None else ""
    context.messages.say("warning" if calibration.sigma0_origin == "assumed" else "info",
                        f"imported {len(files)} OpenCV file(s) into {out}{where} "
                        f"({calibration.left.width} × {calibration.left.height} px); {sigma0_statement(calibration)}")
    if calibration_id is not None:
        use_calibration(context, parent, calibration_id, run)
    return Path(out)


class UseCalibrationDialog(QtWidgets.QDialog):
    """Choose a stored calibration and the pairs and videos it becomes active for (the shown one ticked)."""

    def __init__(self, project, current: str | None, chosen: int | None = None,
                 parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Use a stored calibration")
        self.calibrations = project.calibrations()
        self.choice = QtWidgets.QComboBox()
        for c in self.calibrations:
            sigma = f", σ0 {c.sigma0_px:.3g} px" if c.sigma0_px is not None else ""
            self.choice.addItem(f"{c.id}: {c.name} ({c.phase or 'phase unknown'}{sigma})", c.id)
        if chosen is not None:
            self.choice.setCurrentIndex(max(self.choice.findData(chosen), 0))
        else:
            self.choice.setCurrentIndex(self.choice.count() - 1)
        self.labels = QtWidgets.QListWidget()
        for pair in project.pairs():
            size = calibration_size.media_size(project, pair.label)
            shown = pair.label + (f"  ({size[0]} × {size[1]} px)" if size else "")
            item = QtWidgets.QListWidgetItem(shown)
            item.setData(QtCore.Qt.ItemDataRole.UserRole, pair.label)
            item.setFlags(item.flags() | QtCore.Qt.ItemFlag.ItemIsUserCheckable)
            item.setCheckState(QtCore.Qt.CheckState.Checked if pair.label == current
                               else QtCore.Qt.CheckState.Unchecked)
            self.labels.addItem(item)
        form = QtWidgets.QFormLayout()
        calibration_label = QtWidgets.QLabel("&Calibration:")
        calibration_label.setBuddy(self.choice)
        labels_label = QtWidgets.QLabel("&Active for (Space ticks):")
        labels_label.setBuddy(self.labels)
        form.addRow(calibration_label, self.choice)
        form.addRow(labels_label, self.labels)
        buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.StandardButton.Ok
                                             | QtWidgets.QDialogButtonBox.StandardButton.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addLayout(form)
        layout.addWidget(buttons)

    def calibration_id(self) -> int | None:
        return self.choice.currentData()

    def active_for(self) -> list[str]:
        return [self.labels.item(i).data(QtCore.Qt.ItemDataRole.UserRole) for i in range(self.labels.count())
                if self.labels.item(i).checkState() == QtCore.Qt.CheckState.Checked]


def activate_calibration(context: WindowContext, parent: QtWidgets.QWidget, calibration_id: int,
                         labels: list[str]) -> bool:
    """Make stored calibration ``calibration_id`` the active one of pairs/videos ``labels`` and show the
    current pair with it. Pairs or videos of another picture size than the calibration's are left as they
    were and named (both sizes); a failure is one message and changes nothing shown."""
    project = context.need_project()
    if project is None:
        return False
    try:
        calibration = read_calibration(project, calibration_id)
        bad = {label: line for label in labels
               for line in calibration_size.misfits(project, calibration, [label], f"calibration {calibration_id}")}
        good = [label for label in labels if label not in bad]
        for label in good:
            calibration_size.activate(project, label, calibration_id)
    except UsvipsError as error:
        context.messages.error(f"the calibration was not made active: {error}")
        return False
    if context.workspace.pair in good:
        context.workspace.reshow_pair()
    if bad:
        context.messages.error(f"calibration {calibration_id} was not made active for {len(bad)} of "
                                     f"{len(labels)}: " + "; ".join(bad.values()))
        return bool(good)
    context.messages.info(f"calibration {calibration_id} is active for {', '.join(labels) or 'no pair'}")
    return True


def use_calibration(context: WindowContext, parent: QtWidgets.QWidget, chosen: int | None = None,
                    run: Callable[[UseCalibrationDialog], object] = lambda d: d.exec()) -> bool:
    """Calibration › Use a stored calibration…: choose one and the pairs and videos it is for."""
    project = context.need_project()
    if project is None:
        return False
    if not project.calibrations():
        context.messages.error("the project has no calibration yet: import one (Calibration › Import a "
                                     "USVIPS calibration…, File › Import calibration (OpenCV)…) or calibrate")
        return False
    dialog = UseCalibrationDialog(project, context.workspace.pair, chosen, parent)
    if not run(dialog) or dialog.calibration_id() is None:
        return False
    return activate_calibration(context, parent, dialog.calibration_id(), dialog.active_for())


def import_usvips_calibration(context: WindowContext, parent: QtWidgets.QWidget, path: str | Path | None = None,
                              run: Callable[[UseCalibrationDialog], object] = lambda d: d.exec()) -> int | None:
    """Calibration › Import a USVIPS calibration…: a calibration file (`usvips calibrate`, another
    project's) read and checked, stored in the project, then made active where the user says (the shown
    pair or video ticked)."""
    project = context.need_project()
    if project is None:
        return None
    if path is None:
        path, _ = QtWidgets.QFileDialog.getOpenFileName(parent, "USVIPS calibration", context.start_folder(),
                                                    "Calibrations (*.json)")
        if not path:
            return None
    try:
        calibration = load_calibration(path)
        calibration_id = store_calibration(project, Path(path).stem, calibration)
    except UsvipsError as error:
        context.messages.error(f"import failed, nothing stored: {error}")
        return None
    context.messages.info(f"{Path(path).name} stored in the project as calibration {calibration_id}")
    use_calibration(context, parent, calibration_id, run)
    return calibration_id


def export_calibration(context: WindowContext, parent: QtWidgets.QWidget,
                       source: str | Path | StereoCalibration | None = None,
                       out: str | Path | None = None) -> list[str] | None:
    """A calibration (default: the current pair's in the open project, else a file) → OpenCV's stereo
    file; what OpenCV cannot hold (the housing, …) is shown as warnings and returned."""
    try:
        chosen = _calibration_to_write(context, parent, source, out, "Export calibration (OpenCV)", "stereo.yml",
                                       "OpenCV FileStorage (*.yml *.yaml *.xml *.json)")
        if chosen is None:
            return None
        calibration, name, out = chosen
        left_out = write_opencv_stereo(calibration, out)
    except UsvipsError as error:
        context.messages.error(f"export failed, nothing written: {error}")
        return None
    for line in left_out:
        context.messages.warning(f"OpenCV cannot hold: {line}")
    context.messages.say("warning" if left_out else "info",
                        f"exported {name} to {out}" + (f"; {len(left_out)} thing(s) left out (see the log)"
                                                       if left_out else ""))
    return left_out


def calibration_report(context: WindowContext, parent: QtWidgets.QWidget,
                       source: str | Path | StereoCalibration | None = None,
                       out: str | Path | None = None) -> Worker | None:
    """Write a calibration's PDF report in the window's worker (progress and Cancel in the status bar)."""
    try:
        chosen = _calibration_to_write(context, parent, source, out, "Calibration report", "calibration_report.pdf",
                                       "PDF (*.pdf)")
    except UsvipsError as error:
        context.messages.error(str(error))
        return None
    if chosen is None:
        return None
    calibration, name, out = chosen
    path, data = (name if isinstance(source, str | Path) else None), None
    project = context.workspace.project
    if source is None and project is not None and project.calibrations():
        # a calibration of the project: its data found as the command line finds them (the files it was
        # made from, beside the project), else the control and observations the project holds
        path, data = project.path, project_report_data(project, calibration)
    return context.jobs.run(report_job(calibration, out, path, data), "calibration report",
                            lambda pages: context.messages.info(f"wrote {out} ({pages} pages)"))


def project_report_data(project, calibration: StereoCalibration):
    """What a project's calibration was made from, for its report: the files its ``source`` names when
    they are beside the project (as for the command line's report of its file), otherwise the project's
    control points and its observations of the calibration's pairs (the role of its phase)."""
    from usvips.io.calibration_report import ReportData, find_data

    found = find_data(calibration, project.path)
    if found.control is not None and found.observations is not None:
        return found
    role = "calibration-air" if calibration.phase == "air" else "calibration-water"
    labels = {p.label for p in project.pairs()}
    parts = [project.control_observations(role, pair) for pair in calibration.stations if pair in labels]
    parts = [part for part in parts if len(part.ids)]
    if not parts or not len(project.control().ids):
        return found
    observations = StereoObservations(tuple(i for part in parts for i in part.ids),
                                      np.vstack([part.left for part in parts]),
                                      np.vstack([part.right for part in parts]),
                                      tuple(pair for part in parts for pair in part.pairs))
    held = f"control and observations of {', '.join(calibration.stations)} held by the project"
    return ReportData(project.control(), observations, [("project", str(project.path), held)])


# ---------------------------------------------------------------------------- deployment and georeference
_LABELS = {"opcode": "OpCode (sample id)", "date": "Date (YYYY-MM-DD)", "time": "Time (HH:MM[:SS], local)",
           "latitude": "Latitude (°, WGS 84)", "longitude": "Longitude (°, WGS 84)", "depth_m": "Depth (m)",
           "site": "Site", "location": "Location", "status": "Status (e.g. Fished, No-take)",
           "successful_count": "Successful for counts", "successful_length": "Successful for lengths",
           "observer": "Observer", "comment": "Comment"}
_CAMPAIGN = {"campaign_id": "CampaignID", "project": "Project", "method": "Method",
             "sampling_design": "Sampling design", "submitter": "Submitter", "institution": "Institution",
             "start_date": "Start", "end_date": "End", "image_analysis": "Image analysis", "comment": "Comment"}
#: the campaign fields' forms, shown in the empty field (short labels leave the fields room for a CampaignID)
_CAMPAIGN_HINTS = {"campaign_id": "YYYY-MM_Project.name_Method", "method": "e.g. stereo-BRUVs",
                   "start_date": "YYYY-MM-DD", "end_date": "YYYY-MM-DD"}
#: a CampaignID as long as a usual one: its field shows it whole
TYPICAL_CAMPAIGN_ID = "2024-03_Abrolhos.Reef_stereo-BRUVs"
_GEO = {"latitude": "Origin latitude (°)", "longitude": "Origin longitude (°)", "depth_m": "Origin depth (m)",
        "heading_deg": "Heading of +X (° from north, clockwise)"}
#: the georeference's fields by the parameter its errors name (:class:`usvips.core.deployment.Georeference`)
_GEO_PARAMETERS = {"latitude": "origin latitude", "longitude": "origin longitude", "depth_m": "origin depth",
                   "heading_deg": "heading"}


class DeploymentDialog(QtWidgets.QDialog):
    """The project's deployment metadata (CheckEM's _Metadata.csv), the georeference of its object frame
    (for GeoJSON) and the campaign (GlobalArchive's CampaignID, project, method …). OK stores them in one
    transaction; a bad value is named under the form and the dialog stays open with everything typed."""

    def __init__(self, project, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.project = project
        #: what the dialog read (the versions OK names: a colleague's change meanwhile is refused by name)
        self._read = (project.deployments(), project.georeference(), project.campaign())
        self.setWindowTitle("Deployment and georeference")
        self.fields: dict[str, QtWidgets.QWidget] = {}
        form = QtWidgets.QFormLayout()
        self.scope = QtWidgets.QComboBox()  # the whole project, or one stereo video (a deployment of its own)
        self.scope.addItem("the whole project", "")
        for video in project.videos():
            self.scope.addItem(f"video {video.label}", video.label)
        form.addRow("Deployment of", self.scope)
        for name in DEPLOYMENT_FIELDS:
            widget = QtWidgets.QCheckBox() if name.startswith("successful_") else QtWidgets.QLineEdit()
            self.fields[name] = widget
            form.addRow(_LABELS[name], widget)
        self._shown = ""
        self._typed: dict[str, dict] = {}
        self._show_scope("")
        self.scope.currentIndexChanged.connect(lambda _: self._show_scope(self.scope.currentData()))
        self.georeferenced = QtWidgets.QGroupBox("Georeference of the object frame (Z up)")
        self.georeferenced.setCheckable(True)
        geo = project.georeference()
        self.georeferenced.setChecked(geo is not None)
        geo_form = QtWidgets.QFormLayout(self.georeferenced)
        self.geo_fields: dict[str, QtWidgets.QLineEdit] = {}
        for name, label in _GEO.items():
            widget = QtWidgets.QLineEdit("" if geo is None else repr(getattr(geo, name)))
            self.geo_fields[name] = widget
            geo_form.addRow(label, widget)
        self.campaigned = QtWidgets.QGroupBox("Campaign (GlobalArchive)")
        self.campaigned.setCheckable(True)
        campaign = project.campaign()
        self.campaigned.setChecked(campaign is not None)
        campaign_form = QtWidgets.QFormLayout(self.campaigned)
        self.campaign_fields: dict[str, QtWidgets.QLineEdit] = {}
        for name, label in _CAMPAIGN.items():
            widget = QtWidgets.QLineEdit(getattr(campaign if campaign is not None else Campaign(), name))
            widget.setPlaceholderText(_CAMPAIGN_HINTS.get(name, ""))
            widget.setToolTip(_CAMPAIGN_HINTS.get(name, ""))
            widget.setMinimumWidth(widget.fontMetrics().horizontalAdvance(TYPICAL_CAMPAIGN_ID) + 16)
            self.campaign_fields[name] = widget
            campaign_form.addRow(label, widget)
        self.message = QtWidgets.QLabel()
        self.message.setStyleSheet("color: #c0392b;")
        self.message.setWordWrap(True)
        buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.StandardButton.Ok
                                             | QtWidgets.QDialogButtonBox.StandardButton.Cancel)
        buttons.accepted.connect(self.store)
        buttons.rejected.connect(self.reject)
        content = QtWidgets.QWidget()
        inner = QtWidgets.QVBoxLayout(content)
        inner.setContentsMargins(0, 0, 0, 0)
        inner.addLayout(form)
        columns = QtWidgets.QHBoxLayout()  # the georeference and the campaign side by side: the form stays short
        columns.addWidget(self.georeferenced, 1)
        columns.addWidget(self.campaigned, 1)
        inner.addLayout(columns)
        # the fields scroll on a short screen (1366 × 768): the message and OK / Cancel always stay in view
        scroll = QtWidgets.QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setFrameShape(QtWidgets.QFrame.Shape.NoFrame)
        scroll.setWidget(content)
        wanted = content.sizeHint()
        screen = (parent.screen() if parent is not None else QtGui.QGuiApplication.primaryScreen()).availableGeometry()
        scroll.setMinimumWidth(min(wanted.width() + scroll.verticalScrollBar().sizeHint().width(), screen.width() - 80))
        scroll.setMinimumHeight(min(wanted.height(), max(200, screen.height() - 200)))
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(scroll, 1)
        layout.addWidget(self.message)
        layout.addWidget(buttons)
        #: each part's fields by the parameter an error names (a bad value is said with its label, its field
        #: outlined and focused): the deployment's, the georeference's and the campaign's
        self.field_errors = {
            "deployment": FormFields({n: (w, _LABELS[n]) for n, w in self.fields.items()}, self.message.setText),
            "georeference": FormFields({_GEO_PARAMETERS[n]: (w, _GEO[n]) for n, w in self.geo_fields.items()},
                                       self.message.setText),
            "campaign": FormFields({n: (w, _CAMPAIGN[n]) for n, w in self.campaign_fields.items()},
                                   self.message.setText)}

    def _typed_now(self) -> dict:
        return {name: (w.isChecked() if isinstance(w, QtWidgets.QCheckBox) else w.text())
                for name, w in self.fields.items()}

    def _show_scope(self, scope: str) -> None:
        """Show one scope's fields: what was typed for it in this dialog, else what is stored."""
        if self._shown in self._typed:
            self._typed[self._shown] = self._typed_now()
        values = self._typed.get(scope)
        if values is None:
            stored = self.project.deployments().get(scope)
            values = {name: (None if stored is None else getattr(stored, name)) for name in DEPLOYMENT_FIELDS}
        for name, widget in self.fields.items():
            value = values[name]
            if isinstance(widget, QtWidgets.QCheckBox):
                widget.setChecked(True if value is None else bool(value))
            else:
                widget.setText("" if value is None else str(value))
        self._shown = scope
        self._typed[scope] = self._typed_now()

    def deployments(self) -> dict[str, Deployment | None]:
        """Scope → the deployment typed for it (None: no OpCode, none); raises :class:`UsvipsError` naming
        a bad value and the scope."""
        self._typed[self._shown] = self._typed_now()
        return {scope: Deployment(**typed) if str(typed["opcode"]).strip() else None
                for scope, typed in self._typed.items()}

    def _deployment_of(self, scope: str) -> Deployment | None:
        """The deployment typed for ``scope``; a bad value shows that scope's fields and raises."""
        typed = self._typed[scope]
        try:
            return Deployment(**typed) if str(typed["opcode"]).strip() else None
        except UsvipsError:
            if scope != self._shown:
                self.scope.setCurrentIndex(self.scope.findData(scope))  # its fields shown, to be corrected
            raise

    def values(self) -> tuple[Deployment | None, Georeference | None]:
        """What the form shows (raises :class:`UsvipsError` naming a bad value); no OpCode: no deployment."""
        return self.deployments()[self._shown], self._georeference()

    def _georeference(self) -> Georeference | None:
        """The georeference typed (None when its box is unticked); raises :class:`UsvipsError` naming a bad value."""
        if not self.georeferenced.isChecked():
            return None
        return Georeference(*(self.geo_fields[n].text() or None for n in ("latitude", "longitude")),
                            self.geo_fields["depth_m"].text() or 0.0, self.geo_fields["heading_deg"].text() or 0.0)

    def campaign(self) -> Campaign | None:
        """The campaign typed (None when its box is unticked); raises :class:`UsvipsError` naming a bad value."""
        if not self.campaigned.isChecked():
            return None
        return Campaign(**{name: widget.text() for name, widget in self.campaign_fields.items()})

    def store(self) -> bool:
        """Store the form (OK); on a bad value say which and stay open."""
        self._typed[self._shown] = self._typed_now()
        scopes = list(self._typed)
        parts = [("deployment", f"{'video ' + scope if scope else 'the project'}: ",
                  lambda scope=scope: self._deployment_of(scope)) for scope in scopes]
        parts += [("georeference", "georeference: ", self._georeference), ("campaign", "campaign: ", self.campaign)]
        typed = []
        for part, where, read in parts:
            try:
                typed.append(read())
            except UsvipsError as error:  # said in the form's terms, its field outlined and focused
                self.field_errors[part].show(error, where)
                return False
        for errors in self.field_errors.values():
            errors.clear()
        *typed_deployments, georeference, campaign = typed
        deployments = dict(zip(scopes, typed_deployments, strict=True))
        try:
            read_deployments, read_georeference, read_campaign = self._read
            with self.project.transaction():
                for scope, deployment in deployments.items():
                    self.project.set_deployment(deployment, scope or None, expected=read_deployments.get(scope))
                self.project.set_georeference(georeference, expected=read_georeference)
                self.project.set_campaign(campaign, expected=read_campaign)
        except UsvipsError as error:
            self.message.setText(str(error))
            return False
        self.accept()
        return True


def edit_deployment(context: WindowContext, parent: QtWidgets.QWidget,
                    run: Callable[[DeploymentDialog], object] = lambda d: d.exec()) -> bool:
    """Project › Deployment and georeference…; ``run`` shows the dialog (tests fill it and press OK)."""
    project = context.need_project()
    if project is None:
        return False
    dialog = DeploymentDialog(project, parent)
    run(dialog)
    accepted = dialog.result() == QtWidgets.QDialog.DialogCode.Accepted
    if accepted:
        context.messages.info("stored the deployment metadata, georeference and campaign")
    dialog.deleteLater()
    return accepted


# ---------------------------------------------------------------------------- the wizard's button
class WizardReport(QtCore.QObject):
    """The calibration wizard's Report (PDF)… button: the session's result with the control and
    observations it used, written in a worker; pressing again while it runs cancels it."""

    def __init__(self, page: QtWidgets.QWizardPage, session, pool: QtCore.QThreadPool | None = None) -> None:
        super().__init__(page)
        self.page, self.session, self.pool = page, session, pool
        self.button = QtWidgets.QPushButton("&Report (PDF)…")  # Alt+R on a wizard's Save page
        self.button.setToolTip("A printable record of this calibration: parameters with sigmas, correlations, "
                               "residual plots, data and provenance")
        self.status = QtWidgets.QLabel()
        self.button.clicked.connect(lambda: self.cancel() if self.worker is not None else self.write())
        self.worker: Worker | None = None

    def report_data(self):
        """The report's data: the session's control and the observations of the pairs it used."""
        import numpy as np

        from usvips.core.observations import StereoObservations
        from usvips.io.calibration_report import ReportData

        rows = [(pair, i) for pair in self.session.pairs for i in self.session.measured(pair)]
        values = np.array([self.session.observations[key] for key in rows], float).reshape(-1, 4)
        observations = StereoObservations(tuple(i for _, i in rows), values[:, :2], values[:, 2:],
                                          tuple(pair for pair, _ in rows))
        files = [("project", str(self.session.project.path), "the project (the wizard's session)")]
        return ReportData(self.session.control, observations, files)

    def write(self, out: str | Path | None = None) -> Worker | None:
        result = self.session.result
        if result is None:
            self.status.setText("Compute a calibration first.")
            return None
        if out is None:
            out, _ = QtWidgets.QFileDialog.getSaveFileName(self.page, "Calibration report",
                                                           "calibration_report.pdf", "PDF (*.pdf)")
            if not out:
                return None
        worker = self.worker = Worker(report_job(result.calibration, out, None, self.report_data()),
                                      "calibration report")
        worker.signals.finished.connect(lambda pages: self._ended(f"Wrote {out} ({pages} pages)."))
        worker.signals.failed.connect(lambda message: self._ended(f"No report: {message}"))
        worker.signals.cancelled.connect(lambda: self._ended("Report cancelled; nothing written."))
        self.button.setText("Cancel the report")
        self.status.setText("Writing the report …")
        return start(worker, self.pool)

    def cancel(self) -> None:
        if self.worker is not None:
            self.worker.cancel()

    def _ended(self, text: str) -> None:
        self.worker = None
        self.button.setText("&Report (PDF)…")
        self.status.setText(text)
