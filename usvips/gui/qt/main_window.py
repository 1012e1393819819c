"""The workstation window: two stereo panes in a splitter, docks for enhancement, objects, the
geo-calculator, the plan view and the log; menus, toolbar, shortcuts and a status bar with the pixel
under the cursor and the last 3-D point with its sigmas.

The window is a controller: it forwards clicks to the :class:`Workspace`, draws what the workspace holds,
and runs image reading and enhancement in worker threads (progress and cancel in the status bar).
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

from usvips.app.opening import open_project
from usvips.core.errors import UsvipsError
from usvips.core.redaction import redact
from usvips.gui import commands, panel_registry
from usvips.gui.commands import TOOL_TIPS
from usvips.gui.lazy_panels import LazyPanels
from usvips.gui.messages import Messages
from usvips.gui.object_cache import project_location, read_stored_objects
from usvips.gui.object_overlay import ObjectOverlay
from usvips.gui.pick_tool import SIDES, TOOLS, describe_point
from usvips.gui.qt import menu_keys
from usvips.gui.qt.annotator_dialog import AnnotatorDialog, save_annotator, saved_annotator
from usvips.gui.qt.error_report import register_window
from usvips.gui.qt.gui_thread_gc import keep_long_lived, release_long_lived
from usvips.gui.qt.jobs import Jobs
from usvips.gui.qt.live_updates import LiveUpdates
from usvips.gui.qt.media_check import MediaCheck
from usvips.gui.qt.on_screen import on_screen
from usvips.gui.qt.pane import StereoPane, pixel_from_item
from usvips.gui.qt.status_bar import StatusBar
from usvips.gui.qt.track_controls import TrackController
from usvips.gui.qt.video_controls import VideoController
from usvips.gui.qt.worker import Cancelled, Worker
from usvips.gui.video_model import format_timecode
from usvips.gui.window_context import Navigation, WindowContext
from usvips.gui.wording import plural
from usvips.gui.workspace import Workspace, pair_image_paths, read_pair
from usvips.io.species_list import read_species_list
from usvips.locations import resources_folder, sample_projects
from usvips.store.annotator import annotating_as
from usvips.store.location import is_server_location, without_password
from usvips.store.records import StaleEditError

SAMPLES = sample_projects()
MAX_RECENT = 8
#: the dialog modules (usvips.gui.qt) commands name as their owner: their functions take the window's
#: context (usvips.gui.window_context) and a parent widget, never the window
DIALOG_MODULES = ("media_dialogs", "exchange_dialogs", "detection_dialogs")
#: a panel's area (usvips.gui.panel_registry) as Qt's dock area
DOCK_AREAS = {area: getattr(QtCore.Qt.DockWidgetArea, f"{area.capitalize()}DockWidgetArea")
              for area in ("left", "right", "top", "bottom")}


#: the quick guide (Help › Quick guide, F1): rich text kept as a resource, not in the code
GUIDE_FILE = "quick_guide.html"


def quick_guide() -> str:
    """The quick guide's text (Qt rich text: a subset of HTML)."""
    return (resources_folder() / GUIDE_FILE).read_text(encoding="utf-8")


def luminance_histogram(image: np.ndarray) -> np.ndarray:
    """Counts of the 256 grey levels (uint16 images binned to 256)."""
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY) if image.ndim == 3 else image
    top = 256 if grey.dtype == np.uint8 else 65536
    return cv2.calcHist([grey], [0], None, [256], [0, top]).ravel()


def pane_title(side: str, pair: str, shape: tuple, video_frame: tuple | None) -> str:
    """A pane's title: the image pair and its size, or the video and this side's frame with its time."""
    if video_frame is None:
        return f"{side.capitalize()} — {pair}  ({shape[1]} × {shape[0]} px)"
    video, left, right, time_s = video_frame
    return f"{side.capitalize()} — {video}, frame {left if side == 'left' else right}  {format_timecode(time_s)}"


class MainWindow(QtWidgets.QMainWindow):
    def __init__(self, workspace: Workspace | None = None, settings: QtCore.QSettings | None = None) -> None:
        super().__init__()
        register_window(self)  # unexpected errors in Qt handlers are shown here (usvips.gui.qt.app)
        self.workspace = workspace or Workspace()
        self.settings = settings or QtCore.QSettings("USVIPS", "usvips")
        #: who is annotating: every store write in the window is made as this name (File › Annotator…)
        self.annotator = saved_annotator(self.settings)
        self.setWindowTitle(self.title())
        self.setObjectName("usvips_main")
        self.pool = QtCore.QThreadPool(self)  # its own pool: finished with the window
        #: the messaging service the window's parts are handed (usvips.gui.messages): the window shows it
        self.messages = Messages()
        #: long work off the GUI thread (usvips.gui.qt.jobs), its progress in the status bar
        self.jobs = Jobs(self.pool, self.messages)
        self.workers = self.jobs.workers
        #: what the panels and controllers are handed instead of the window
        self.panes = {side: StereoPane(side) for side in SIDES}
        self.context = WindowContext(self.workspace, self.messages, self.jobs, Navigation(
            self.open_path, self.load_pair, self.refresh_pair_box, self._videos_changed, self._show_video,
            self.set_hint, self.show_review, self._media_resolved), self.settings, self.panes)
        self._display_tokens = dict.fromkeys(SIDES, 0)
        self._pair_worker: Worker | None = None
        self._front_before_observation: QtWidgets.QDockWidget | None = None  # raised again after a record
        self._centre_pending = None  # centres the panes on an object asked for once its pair is shown
        self.selection: list[int] = []
        self.splitter = QtWidgets.QSplitter(QtCore.Qt.Orientation.Horizontal)
        self.splitter.setObjectName("stereo_splitter")
        for side in SIDES:
            self.splitter.addWidget(self.panes[side])
            self.panes[side].clicked.connect(lambda x, y, s=side: self._on_clicked(s, x, y))
            self.panes[side].hovered.connect(lambda x, y, s=side: self._on_hovered(s, x, y))
        # one line above the images for what the user must act on now (held vertices, refused matches):
        # the status bar clips long messages under the readouts; the log keeps every message
        self.hint = QtWidgets.QLabel("")
        self.hint.setObjectName("hint_line")
        self.hint.setContentsMargins(6, 1, 6, 1)
        self.hint.setTextFormat(QtCore.Qt.TextFormat.PlainText)
        self.hint.setWordWrap(True)  # a long error is read whole, on as many lines as it needs
        self.hint.setSizePolicy(QtWidgets.QSizePolicy.Policy.Ignored, QtWidgets.QSizePolicy.Policy.Minimum)
        central = QtWidgets.QWidget()
        column = QtWidgets.QVBoxLayout(central)
        column.setContentsMargins(0, 0, 0, 0)
        column.setSpacing(0)
        column.addWidget(self.hint)
        column.addWidget(self.splitter, 1)
        self.setCentralWidget(central)
        self._build_docks()
        self._build_status_bar()
        self._build_actions()
        self._build_menus_and_toolbar()
        # stereo video: its dock, keys on the panes, decoding in workers
        self.video = VideoController(self, self.context, self.panes, self.forget_pair_loading, self.refresh_pair_box)
        self.media_check = MediaCheck(self, self.context)  # the full check of an opened project's media files
        self.docks["video"] = self._dock("Video", self.video.dock_widget, QtCore.Qt.DockWidgetArea.TopDockWidgetArea)
        self.video.attach_dock(self.docks["video"])
        # issue 25: tracks drawn on the panes and the timeline, instants stored and listed
        self.tracking = TrackController(self, self.context, self.panes, self.video, self.set_tool)
        self._instants_view: QtWidgets.QDialog | None = None  # made when first shown (instants_view)
        table = self.object_list.table
        table.addAction(self.actions["instants_of_listed"])  # in the list's context menu (object_list._context_menu)
        self.video.dock_widget.setEnabled(False)
        ws = self.workspace
        ws.objects_changed.connect(self.video.objects_changed)
        ws.pair_changed.connect(self._on_pair_changed)
        ws.project_changed.connect(self._on_project_changed)
        ws.picks_changed.connect(self._on_picks_changed)
        # the stored objects on the panes, redrawn by id; all of them (another project or pair) in slices, the
        # next slice once the events pending are handled
        self._slice_timer = QtCore.QTimer(self)
        self._slice_timer.setSingleShot(True)
        self._slice_timer.setInterval(1)
        self._next_slice: Callable[[], None] | None = None
        self._slice_timer.timeout.connect(self._run_slice)
        self.overlay = ObjectOverlay(ws, self.panes, later=self._later)
        self.live = LiveUpdates(self)  # colleagues' changes to the open survey shown as they are made
        ws.selection_changed.connect(self._on_selection_changed)
        ws.enhancement_changed.connect(self._on_enhancement_changed)
        ws.message.connect(self.messages.say)
        self.messages.said.connect(self._show_said)
        self.messages.work_started.connect(self._on_work_started)
        self.messages.work_progress.connect(lambda fraction: self.progress.setValue(int(100 * fraction)))
        self.messages.work_ended.connect(self._on_work_ended)
        ws.undo.changed.connect(self._on_undo_changed)
        # an open menu keeps its letters from the image keys (X11: Alt+F, I listed the instants)
        self.menu_keys = menu_keys.install(self, [pane.graphics for pane in self.panes.values()])
        self._restore_layout()
        self.video.videos_changed(None)  # no project, no videos: the Video dock comes with a project that has them
        self._on_undo_changed()
        self.show_message("info", "To begin: File › New project… (then Add image pairs… or Add stereo video…), "
                                  "open a project (Ctrl+O), or try a sample (File › Open sample).")

    # ------------------------------------------------------------------ construction
    def _dock(self, title: str, widget: QtWidgets.QWidget | None,
              area: QtCore.Qt.DockWidgetArea) -> QtWidgets.QDockWidget:
        """A dock holding ``widget`` (None: empty until its panel is made, :meth:`_make_panel`)."""
        dock = QtWidgets.QDockWidget(title, self)
        dock.setObjectName(f"dock_{title.lower().replace(' ', '_').replace('-', '_')}")
        # in a scroll area, so that no panel's minimum size pushes the window past a 1366 x 768 screen
        scroll = QtWidgets.QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setFrameShape(QtWidgets.QFrame.Shape.NoFrame)
        if widget is not None:
            scroll.setWidget(widget)
        dock.setWidget(scroll)
        self.addDockWidget(area, dock)
        return dock

    def _build_docks(self) -> None:
        """One dock per registered panel (:mod:`usvips.gui.panel_registry`); the panels of one area and group
        are tabbed, the first of each in front. A dock starts empty: its panel is made from the window's
        context when the dock is first shown or the panel is first asked for (:meth:`panel`), except the
        panels declared ``at_start``."""
        ws = self.workspace
        # the right-hand panels run the window's full height beside the bottom ones (the object list sits under
        # the image panes): stacked in a column, each gets room without squeezing the list
        self.setCorner(QtCore.Qt.Corner.BottomRightCorner, QtCore.Qt.DockWidgetArea.RightDockWidgetArea)
        self._declared = {panel.id: panel for panel in panel_registry.panels()}
        #: the panels' widgets by panel id, each made when first read (usvips.gui.lazy_panels)
        self.panels = LazyPanels(self._declared, self._make_panel)
        #: the panels' docks by panel id
        self.docks: dict[str, QtWidgets.QDockWidget] = {}
        #: what the window wires to a panel once it is made (the built-in panels the window itself talks to)
        self._when_made = {"review": self._wire_review,
                           "observation": lambda form: form.finished.connect(self._on_observation_finished)}
        groups: dict[tuple[str, str], list[QtWidgets.QDockWidget]] = {}
        for panel in self._declared.values():
            dock = self.docks[panel.id] = self._dock(panel.title, None, DOCK_AREAS[panel.area])
            dock.visibilityChanged.connect(lambda visible, panel_id=panel.id: self._on_dock_shown(panel_id, visible))
            groups.setdefault((panel.area, panel.group), []).append(dock)
        for tabbed in groups.values():
            for first, second in zip(tabbed, tabbed[1:], strict=False):
                self.tabifyDockWidget(first, second)
            tabbed[0].raise_()
        self._size_docks()
        for panel in self._declared.values():
            if panel.at_start:
                self.panel(panel.id)
        ws.object_requested.connect(self._on_object_requested)  # an object on an image pair: that pair, centred
        ws.stored.connect(self._on_stored)

    def _size_docks(self) -> None:
        """The docks at the sizes their panels ask for at first start (:class:`usvips.gui.panel_registry.Panel`'s
        ``size`` across their area and ``length`` along it); a saved layout restored later replaces them."""
        horizontal, vertical = QtCore.Qt.Orientation.Horizontal, QtCore.Qt.Orientation.Vertical
        for panel in self._declared.values():
            across = panel.area in ("left", "right")
            if panel.size is not None:
                self.resizeDocks([self.docks[panel.id]], [panel.size], horizontal if across else vertical)
            if panel.length is not None:
                self.resizeDocks([self.docks[panel.id]], [panel.length], vertical if across else horizontal)

    def panel(self, panel_id: str) -> QtWidgets.QWidget:
        """The panel ``panel_id``'s widget, made now if it has not been (commands, controllers and tests
        ask for a panel here; its dock is not shown by asking)."""
        return self.panels[panel_id]

    def _make_panel(self, panel_id: str) -> QtWidgets.QWidget:
        """Make a declared panel from the window's context and put it in its dock."""
        widget = self._declared[panel_id].factory(self.context)
        dock = self.docks[panel_id]
        dock.widget().setWidget(widget)
        if callable(getattr(widget, "on_shown", None)):  # e.g. the QA list is checked when it comes to the front
            dock.visibilityChanged.connect(widget.on_shown)
        if panel_id in self._when_made:
            self._when_made[panel_id](widget)
        return widget

    def _on_dock_shown(self, panel_id: str, visible: bool) -> None:
        """A dock came to the front (or went): its panel is made the first time it does."""
        if visible and not self.panels.is_built(panel_id):
            widget = self.panel(panel_id)
            if callable(getattr(widget, "on_shown", None)):  # connected after this signal was sent
                widget.on_shown(True)

    def _wire_review(self, review: QtWidgets.QWidget) -> None:
        # the proposals on the images with the handles that correct their keypoints, also when they were
        # stored before this window was opened (usvips detect, an earlier session)
        from usvips.gui.qt.proposal_handles import show_proposals  # light: no detection imported

        show_proposals(self.context)
        review.reviewed.connect(self.object_list.show_review)
        review.review_read.connect(self.object_list.show_review)  # someone else's review, read again
        review.history_requested.connect(self.object_list.show_history)

    @property
    def instants_view(self) -> QtWidgets.QDialog:
        """The instants of an object (``I``, Measure menu), a dialog made the first time it is wanted: its
        module and model are not imported at start."""
        if self._instants_view is None:
            from usvips.gui.qt.instants_view import InstantsView

            self._instants_view = InstantsView(self.workspace, self)
            self._instants_view.frame_requested.connect(self.workspace.request_object)  # the video hears it
        return self._instants_view

    #: the built-in panels the window itself talks to, by name (made when first read)
    enhancement = property(lambda self: self.panel("enhancement"))
    object_list = property(lambda self: self.panel("objects"))
    calculator = property(lambda self: self.panel("calculator"))
    plan = property(lambda self: self.panel("plan"))
    log = property(lambda self: self.panel("log"))
    observation = property(lambda self: self.panel("observation"))
    planner = property(lambda self: self.panel("planner"))
    qa = property(lambda self: self.panel("qa"))
    review = property(lambda self: self.panel("review"))

    def _build_status_bar(self) -> None:
        bar = StatusBar(self)
        self.setStatusBar(bar)
        self.pixel_label = QtWidgets.QLabel("")
        self.pixel_label.setMinimumWidth(260)
        self.point_label = QtWidgets.QLabel("")
        self.progress = QtWidgets.QProgressBar()
        self.progress.setMaximumWidth(160)
        self.progress.hide()
        self.cancel_button = QtWidgets.QPushButton("Cancel")
        self.cancel_button.hide()
        self.cancel_button.clicked.connect(self.cancel_work)
        bar.addPermanentWidget(self.point_label)
        bar.addPermanentWidget(self.pixel_label)
        bar.addPermanentWidget(self.progress)
        bar.addPermanentWidget(self.cancel_button)

    def _command_handler(self, command: commands.Command):
        """The function a command runs: ``owner.method`` resolved against the window's controllers (a dialog
        module's function is given the window's context and the window as its dialogs' parent widget), called
        with the command's ``args``."""
        owner, _, method = command.handler.rpartition(".")
        if owner in DIALOG_MODULES:  # imported when one of its commands is first run, not at start-up
            module = f"usvips.gui.qt.{owner}"
            return lambda *_: getattr(importlib.import_module(module), method)(self.context, self, *command.args)
        owners = {"window": self, "tracking": lambda: self.tracking}
        target = owners[owner]
        if owner == "window":
            return lambda *_: getattr(self, method)(*command.args)
        return lambda *_: getattr(target(), method)(*command.args)  # a controller made after the actions

    def _build_actions(self) -> None:
        """One QAction per declared command (:mod:`usvips.gui.commands`): its keys in its scope, its tip
        with the keys, checkable and exclusive as declared."""
        self.actions: dict[str, QtGui.QAction] = {}
        groups: dict[str, QtGui.QActionGroup] = {}
        for command in commands.commands():
            action = QtGui.QAction(command.title, self)
            keys = [QtGui.QKeySequence(getattr(QtGui.QKeySequence.StandardKey, k[4:])) if k.startswith("std:")
                    else QtGui.QKeySequence(k) for k in command.keys]
            if keys:
                action.setShortcuts(keys)
            tip = command.tip or command.title.replace("&", "")
            action.setToolTip(tip + (f" ({action.shortcut().toString()})" if keys else ""))
            action.setStatusTip(tip)
            action.setCheckable(command.checkable)
            if command.short:
                action.setIconText(command.short)  # short toolbar labels: the toolbar fits 1366 px
            action.triggered.connect(self._command_handler(command))
            if command.scope == "images":  # its keys work only while the images have the focus (click an image)
                action.setShortcutContext(QtCore.Qt.ShortcutContext.WidgetWithChildrenShortcut)
                self.splitter.addAction(action)
            elif command.scope == "object list":  # added to the list's table (and its context menu) by the window
                action.setShortcutContext(QtCore.Qt.ShortcutContext.WidgetShortcut)
            else:
                self.addAction(action)
            if command.exclusive:
                groups.setdefault(command.exclusive, QtGui.QActionGroup(self)).addAction(action)
            self.actions[command.id] = action
        self.tool_actions, self.loupe_actions = groups["tools"], groups["loupe"]
        self.actions["auto_match"].setChecked(self.workspace.settings.auto_match)
        self.actions["snap"].setChecked(self.workspace.settings.snap)
        self.actions["loupe"].setChecked(True)
        self.actions["tool_pick"].setChecked(True)

    def _update_enablement(self) -> None:
        """Each command with a condition enabled as its condition holds now."""
        undo = self.workspace.undo
        holds = {"can_undo": undo.undo_label is not None, "can_redo": undo.redo_label is not None}
        for command in commands.commands():
            if command.enabled_when:
                self.actions[command.id].setEnabled(holds[command.enabled_when])

    def _build_menus_and_toolbar(self) -> None:
        """The menus from the declared commands, submenus and sections (:data:`usvips.gui.commands.ITEMS`),
        a separator between groups; then the toolbar."""
        a = self.actions
        self.menus: dict[str, QtWidgets.QMenu] = {name: self.menuBar().addMenu(title) for name, title in commands.MENUS}
        last_group: dict[str, str] = {}
        for item in commands.ITEMS:
            parent = item.menu
            if parent is None:
                continue
            menu = self.menus[parent]
            if parent in last_group and last_group[parent] != item.group:
                menu.addSeparator()
            last_group[parent] = item.group
            if isinstance(item, commands.Command):
                menu.addAction(a[item.id])
            elif isinstance(item, commands.Submenu):
                self.menus[item.path] = menu.addMenu(item.title)
            else:  # a section the window fills: the panels' docks
                for panel_id, dock in self.docks.items():
                    if panel_id not in a:  # a panel with its own command (QA panel, Review mode) is listed once
                        menu.addAction(dock.toggleViewAction())
        self.samples_menu = self.menus["File/Open sample"]
        for sample in sorted(SAMPLES.glob("*/project.json")) if SAMPLES.is_dir() else []:
            self.samples_menu.addAction(sample.parent.name, lambda p=sample.parent: self.open_path(p))
        self.samples_menu.setEnabled(bool(self.samples_menu.actions()))
        self.recent_menu = self.menus["File/Recent projects"]
        self._fill_recent_menu()
        bar = self.addToolBar("Main")
        bar.setObjectName("main_toolbar")
        bar.addAction(a["open"])
        bar.addWidget(QtWidgets.QLabel(" Pair "))
        self.pair_box = QtWidgets.QComboBox()
        self.pair_box.setMinimumContentsLength(10)
        self.pair_box.setToolTip("the image pair shown")
        self.pair_box.activated.connect(lambda _: self.load_pair(self.pair_box.currentText()))
        bar.addWidget(self.pair_box)
        bar.addSeparator()
        for tool in TOOLS:
            bar.addAction(a[f"tool_{tool}"])
        bar.addWidget(QtWidgets.QLabel(" Attribute "))
        self.attribute_box = QtWidgets.QComboBox()
        self.attribute_box.setEditable(True)
        self.attribute_box.setMinimumContentsLength(12)
        self.attribute_box.setToolTip("attribute of the next stored object (from the vocabulary, or type a new one "
                                      "and press Enter to keep it)")
        self.attribute_box.setInsertPolicy(QtWidgets.QComboBox.InsertPolicy.NoInsert)
        self.attribute_box.lineEdit().returnPressed.connect(self._on_attribute_entered)
        self.attribute_box.currentTextChanged.connect(self._on_attribute_changed)
        bar.addWidget(self.attribute_box)
        bar.addAction(a["finish"])
        bar.addSeparator()
        for name in ("snap", "auto_match", "undo", "redo"):
            bar.addAction(a[name])
        bar.addSeparator()
        for name in ("fit", "one", "box", "link", "loupe"):
            bar.addAction(a[name])

    def open_calibration_wizard(self, phase: str, resume: bool | None = None):
        """Start (or resume) a calibration wizard on the open project; returns the wizard, shown."""
        from usvips.gui.calibration_session import CalibrationSession
        from usvips.gui.qt.calibration_wizard import CalibrationWizard

        project = self.workspace.project
        if project is None:
            self.show_message("error", "open a project first: the calibration uses its pairs and control")
            return None
        try:
            session = None
            if project.draft(f"calibration-{phase}") is not None:
                if resume is None:
                    answer = QtWidgets.QMessageBox.question(
                        self, "Resume?", "A half-finished calibration of this kind is saved in the project. "
                        "Resume it? (No starts afresh and forgets it.)")
                    resume = answer == QtWidgets.QMessageBox.StandardButton.Yes
                session = CalibrationSession.resume(project, phase) if resume else None
            session = session or CalibrationSession(project, phase)
        except UsvipsError as error:
            self.show_message("error", str(error))
            return None
        wizard = CalibrationWizard(session, self)
        wizard.saved.connect(self._on_calibration_saved)
        wizard.show()
        self.wizard = wizard
        return wizard

    def _on_calibration_saved(self, calibration_id: int) -> None:
        # say what it is active for, as the save page did (it may be for none: no pair of its medium yet)
        project = self.workspace.project
        active = [p.label for p in project.pairs() if project.active_calibration(p.label) == calibration_id]
        self.show_message("info", f"calibration {calibration_id} stored, active for "
                          + (", ".join(active) if active else "none (choose it for a pair later)"))
        self.workspace.reshow_pair()
        self._draw_control()

    def show_guide(self) -> None:
        QtWidgets.QMessageBox.information(self, "USVIPS — quick guide", quick_guide())

    def keys_text(self) -> str:
        """Help › Keys: every declared command with its keys (as this platform writes them) and where they
        work, from the one declaration of the commands (:mod:`usvips.gui.commands`)."""
        import html  # here, not at start-up: its entity table is large

        native = QtGui.QKeySequence.SequenceFormat.NativeText

        def key_text(key: str) -> str:
            if key.startswith("std:"):
                return QtGui.QKeySequence(getattr(QtGui.QKeySequence.StandardKey, key[4:])).toString(native)
            return QtGui.QKeySequence(key).toString(native)

        rows = "".join(f"<tr><td><b>{html.escape(keys)}</b></td><td>{html.escape(title)}</td>"
                       f"<td><i>{html.escape(where)}</i></td></tr>"
                       for keys, title, where in commands.key_list(key_text))
        return f"<table cellspacing='4'>{rows}</table>"

    def show_keys(self) -> QtWidgets.QDialog:
        """Help › Keys…: the key list in a dialog that scrolls (it fits a 1366 × 768 screen) and blocks nothing."""
        dialog = QtWidgets.QDialog(self)
        dialog.setWindowTitle("USVIPS — keys")
        dialog.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        text = QtWidgets.QTextBrowser()
        text.setHtml(self.keys_text())
        buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.StandardButton.Close)
        buttons.rejected.connect(dialog.close)
        column = QtWidgets.QVBoxLayout(dialog)
        column.addWidget(text)
        column.addWidget(buttons)
        height = self.screen().availableGeometry().height() if self.screen() is not None else 768
        dialog.resize(560, min(720, int(height * 0.8)))
        dialog.show()
        return dialog

    # ------------------------------------------------------------------ settings
    def _restore_layout(self) -> None:
        geometry = self.settings.value("window/geometry")
        if geometry is not None:
            self.restoreGeometry(geometry)
        elif self.screen() is not None:  # first start: most of the screen, centred
            available = self.screen().availableGeometry()
            self.resize(int(available.width() * 0.9), int(available.height() * 0.9))
            self.move(available.center() - self.rect().center())
            self._size_docks()  # again at the window's own size (the first were asked of a window not yet sized)
        state = self.settings.value("window/state")
        if state is not None:
            self.restoreState(state)
        splitter = self.settings.value("window/splitter")
        if splitter is not None:
            self.splitter.restoreState(splitter)
        self.actions["link"].setChecked(self.settings.value("view/link", False, type=bool))
        self.apply_link()
        for name, default in (("snap", False), ("auto_match", True), ("loupe", True)):
            self.actions[name].setChecked(self.settings.value(f"view/{name}", default, type=bool))
        self.apply_snap()
        self.apply_auto_match()
        self.apply_loupe()

    def save_layout(self) -> None:
        self.settings.setValue("window/geometry", self.saveGeometry())
        self.settings.setValue("window/state", self.saveState())
        self.settings.setValue("window/splitter", self.splitter.saveState())
        for name in ("link", "snap", "auto_match", "loupe"):
            self.settings.setValue(f"view/{name}", self.actions[name].isChecked())
        self.settings.sync()

    def recent_projects(self) -> list[str]:
        """The recent projects, never with a password (an entry an older USVIPS kept with one is shown and
        kept without it)."""
        value = self.settings.value("recent", [])
        listed = [value] if isinstance(value, str) else list(value or [])
        return list(dict.fromkeys(without_password(p) if is_server_location(p) else redact(p) for p in listed))

    def _remember(self, path: Path | str) -> None:
        path = without_password(path) if is_server_location(path) else redact(path)
        recent = [str(path)] + [p for p in self.recent_projects() if p != str(path)]
        self.settings.setValue("recent", recent[:MAX_RECENT])
        self._fill_recent_menu()

    def _fill_recent_menu(self) -> None:
        self.recent_menu.clear()
        for path in self.recent_projects():
            self.recent_menu.addAction(path, lambda p=path: self.open_path(p))
        self.recent_menu.setEnabled(bool(self.recent_projects()))

    def changeEvent(self, event: QtCore.QEvent) -> None:  # noqa: N802 (Qt's name)
        super().changeEvent(event)
        if event.type() == QtCore.QEvent.Type.ActivationChange and self.isActiveWindow():
            self.review_states_again()

    def review_states_again(self) -> None:
        """The window has the focus again: the review of the object shown — review mode's current one, else
        the one object selected in the object list — is read again (one query), so that a review another
        annotator made meanwhile appears."""
        if self.workspace.project is None:
            return
        if self.panels.is_built("review") and on_screen(self.review):  # not a tab behind another
            self.review.refresh_current()
        elif len(self.workspace.selection) == 1:
            self.object_list.refresh_review(self.workspace.selection[0])

    def closeEvent(self, event: QtGui.QCloseEvent) -> None:  # noqa: N802 (Qt's name)
        if not self.confirm_drop_unfinished("quit"):
            event.ignore()
            return
        self.save_layout()
        self.cancel_work()
        self.video.shutdown()  # the seek-proxy build in the background
        self.pool.waitForDone(5000)
        for panel in self.panels.built().values():  # a panel never made has nothing to clean up
            if callable(getattr(panel, "cleanup", None)):
                panel.cleanup()
        self.media_check.project_closed()
        self.workspace.close_project()
        super().closeEvent(event)

    def confirm_drop_unfinished(self, doing: str) -> bool:
        """Ask before ``doing`` something that drops the object being digitised: store it, drop it or stay."""
        digitising = self.workspace.pick_tool.digitising
        if not digitising.vertices or self.workspace.project is None:
            return True
        answer = self.ask_unfinished(f"The {digitising.kind} being digitised has {len(digitising.vertices)} "
                                     f"vertices and is not stored. Store it before you {doing}?")
        if answer == "stay":
            return False
        if answer == "save":
            return self._guarded(self.workspace.pick_tool.finish_object, self.workspace.pick_tool.attribute, "")
        return True

    def ask_unfinished(self, question: str) -> str:
        """Ask about a half-made object: ``"save"`` (store it), ``"discard"`` or ``"stay"``."""
        buttons = QtWidgets.QMessageBox.StandardButton
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Question, "Unfinished object", question,
                                    buttons.Save | buttons.Discard | buttons.Cancel, self)
        box.setDefaultButton(buttons.Save)
        answer = box.exec()
        return {buttons.Save: "save", buttons.Discard: "discard"}.get(answer, "stay")

    # ------------------------------------------------------------------ messages
    def show_message(self, level: str, text: str) -> None:
        """Say ``text`` through the messaging service (the window's own messages; its parts are handed
        :attr:`messages`)."""
        self.messages.say(level, text)

    def _show_said(self, level: str, text: str) -> None:
        """Errors and warnings go to the status bar (red / amber) and the line above the images (the log
        panel listens itself); nothing raises into Qt; no password is ever shown (the service redacts,
        :func:`usvips.core.redaction.redact`)."""
        colour = {"error": "#ff6b6b", "warning": "#f0b400"}.get(level, "")
        self.statusBar().setStyleSheet(f"QStatusBar {{ color: {colour}; }}" if colour else "")
        self.statusBar().showMessage(text, 0 if level != "info" else 15000)
        self.set_hint(text, level)

    def set_hint(self, text: str, level: str = "info") -> None:
        """The line above the images (full text in its tooltip when the window is narrow)."""
        colour = {"error": "#ff6b6b", "warning": "#f0b400"}.get(level, "")
        self.hint.setStyleSheet(f"color: {colour};" if colour else "")
        self.hint.setText(text)
        self.hint.setToolTip(text)

    def _guarded(self, function, *args) -> bool:
        try:
            function(*args)
        except UsvipsError as error:
            self.show_message("error", str(error))
            return False
        return True

    # ------------------------------------------------------------------ project and pairs
    def start_folder(self, name: str = "") -> str:
        """Where a file dialog opens: the open project's folder (else the home folder), with ``name``."""
        return self.context.start_folder(name)

    def _videos_changed(self, project) -> None:
        self.video.videos_changed(project)

    def _media_resolved(self, stored_paths) -> None:
        self.media_check.resolved(stored_paths)

    def _show_video(self, label: str, after=None) -> bool:
        """Show video ``label``'s first frame; ``after()`` once it is shown (:class:`Navigation`)."""
        if after is None:
            return self.video.open_video(label)

        def shown(_frame: int) -> None:
            self.video.shown.disconnect(shown)
            after()

        self.video.shown.connect(shown)
        opened = self.video.open_video(label)
        if not opened:
            self.video.shown.disconnect(shown)
        return opened

    def open_dialog(self) -> None:
        start = self.start_folder() if self.workspace.project is not None else str(
            SAMPLES if SAMPLES.is_dir() else Path.home())
        path, _ = QtWidgets.QFileDialog.getOpenFileName(
            self, "Open project", start,
            "USVIPS projects (*.usvips);;Sample descriptions (project.json)")
        if path:
            self.open_path(Path(path).parent if Path(path).name == "project.json" else path)

    def open_path(self, path: str | Path, pair: str | None = None) -> bool:
        """Open a project file, or a sample directory (its project file is created on first use), showing
        ``pair`` (default: the pair shown last in this project, else the first)."""
        server = is_server_location(path)  # a survey on a server: its URL, not a file path
        path = path if server else Path(path)
        if not self.confirm_drop_unfinished("open another project"):
            return False
        try:
            with annotating_as(self.annotator):  # the project's writes are made as the window's annotator
                project = open_project(path)
        except UsvipsError as error:
            self.show_message("error", str(error))
            return False
        self.media_check.project_closed()  # the previous project's check stops reading
        # every model is new and every view forgets the previous project by itself (project_changed)
        self.workspace.open_project(project, deferred=True)  # the objects arrive from a worker
        self.read_objects()
        self.media_check.project_opened(project)  # every media file read whole in a worker, changed ones named
        self._remember(without_password(path) if server else project.path.resolve())
        self.setWindowTitle(self.title())
        self.show_message("info", f"opened {project.path}")
        labels = self.workspace.image_pairs()
        self.refresh_pair_box()
        videos = [v.label for v in project.videos()]
        if (not labels and videos) or (pair is not None and pair in videos):  # show a stereo video
            return self.video.open_video(pair if pair in videos else videos[0])
        if not labels and not project.pairs():
            self.show_message("info", f"{project.path.name} is empty: add your images (File › Add image pairs…) "
                                      "or a stereo video (File › Add stereo video…)")
            return True
        if not labels:
            self.show_message("warning", f"{project.path.name} has no images (observations only): calibrate it "
                                         "from its observations with the Calibration menu")
            return True
        if pair is not None and pair not in labels:
            self.show_message("error", f"{project.path.name} has no image pair {pair!r}; pairs: {', '.join(labels)}")
            pair = None
        last = self.settings.value(f"pair/{project.path}")
        if pair is None and last in videos and self.video.open_video(last):  # back where the user was
            frame = self.settings.value(f"frame/{project.path}", -1, type=int)
            if frame >= 0:
                self.video.request(frame)
            return True
        self.load_pair(pair or (last if last in labels else labels[0]))
        return True

    EXPORT_FILTERS = {"Objects CSV (*.csv)": ".csv", "Vertices CSV (*.vertices.csv)": ".vertices.csv",
                      "GeoJSON (*.geojson)": ".geojson", "PLY (*.ply)": ".ply",
                      "EventMeasure / CheckEM tables (*.em.txt)": ".em.txt"}

    def export_dialog(self) -> None:
        if self.workspace.project is None:
            self.show_message("error", "open a project first")
            return
        start = str(self.workspace.project.path.with_suffix(".csv"))
        path, chosen = QtWidgets.QFileDialog.getSaveFileName(self, "Export objects", start,
                                                             ";;".join(self.EXPORT_FILTERS))
        if path:
            self.export_objects(self.export_path(path, chosen))

    @classmethod
    def export_path(cls, path: str, chosen_filter: str) -> str:
        """The file to write: the name as typed when it already ends with a known export suffix (typing
        ``fish.geojson`` with the CSV filter writes GeoJSON), else with the chosen filter's suffix."""
        if any(path.lower().endswith(suffix) for suffix in cls.EXPORT_FILTERS.values()):
            return path
        return path + cls.EXPORT_FILTERS.get(chosen_filter, "")

    def save_as_dialog(self) -> None:
        if self.workspace.project is None:
            self.show_message("error", "open a project first")
            return
        start = self.workspace.project.path.with_name(self.workspace.project.path.stem + "-copy.usvips")
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save the project as", str(start),
                                                        "USVIPS projects (*.usvips)")
        if path:
            self.save_as(path if path.endswith(".usvips") else path + ".usvips")

    def save_as(self, path: str | Path) -> bool:
        """Copy the open project to ``path`` (a new file) and go on working in the copy, on the same pair."""
        project = self.workspace.project
        if project is None:
            self.show_message("error", "open a project first")
            return False
        if not self.confirm_drop_unfinished("save a copy"):
            return False
        try:
            copy = project.copy_to(path)
        except UsvipsError as error:
            self.show_message("error", f"nothing saved: {error}")
            return False
        if self.open_path(copy, self.workspace.pair):
            self.show_message("info", f"saved a copy as {copy}; you are now working in the copy (saved as you go)")
        return True

    def species_dialog(self) -> None:
        path, _ = QtWidgets.QFileDialog.getOpenFileName(self, "Species list (family, genus, species, code)",
                                                        self.start_folder(), "CSV (*.csv *.txt)")
        if path:
            self.import_species(path)

    def import_species(self, path: str | Path) -> bool:
        """Make a CSV species list the project's (type-ahead in the observation form)."""
        if self.workspace.project is None:
            self.show_message("error", "open a project first")
            return False
        try:
            species = read_species_list(path)
            self.workspace.project.set_species_list(species)
        except UsvipsError as error:
            self.show_message("error", f"species list not imported: {error}")
            return False
        self.observation.refresh_species()
        self.object_list.refresh()  # the quality column's species rule (the one verdict) with the new maxima
        self.qa.schedule()  # and the QA panel's
        self.show_message("info", f"{len(species)} species from {path} are the project's species list")
        return True

    def _on_stored(self, object_id: int) -> None:
        """After a measurement: the observation form, if the user wants it, takes the keyboard — not for
        an object stored from track proposals, which joins its object as an instant (the object's record
        holds the species)."""
        if self.observation.ask.isChecked() and self.tracking.joins_as_instant(object_id) is None:
            dock = self.docks["observation"]
            # the panel in front of it (the object list, showing the new length) comes back when it is done
            group = [d for d in (dock, *self.tabifiedDockWidgets(dock)) if d.isVisible()]
            front = [d for d in group if not d.visibleRegion().isEmpty()]
            self._front_before_observation = front[0] if front and front[0] is not dock else None
            dock.show()
            dock.raise_()
            self.observation.begin(object_id)
        else:
            self.observation.load(object_id)

    def export_objects(self, path: str | Path) -> None:
        """Write the project's objects (format by suffix; ``.em.txt`` writes EventMeasure-style tables)."""
        from usvips.app.project_export import export_project

        skipped: list[str] = []
        try:
            count = export_project(self.workspace.project, path, skipped=skipped)
        except UsvipsError as error:
            self.show_message("error", f"export failed, nothing written: {error}")
            return
        for reason in skipped:
            self.show_message("warning", f"not exported: {reason}")
        self.show_message("info", f"exported {count} objects to {path}")

    def load_pair(self, label: str) -> None:
        """Read the pair's images in a worker, then show them."""
        project = self.workspace.project
        if project is None or not label:
            return
        try:
            paths = pair_image_paths(project, label)
        except UsvipsError as error:
            self.show_message("error", str(error))
            return

        def job(progress, cancelled):
            images = read_pair(paths)
            if cancelled():
                raise Cancelled
            return images

        def show(images) -> None:
            if worker is self._pair_worker:  # a pair chosen later wins over one still loading
                self.workspace.set_pair(label, *images)

        self.forget_pair_loading()
        worker = self._pair_worker = self.run_worker(job, f"reading pair {label}", show)

    def read_objects(self) -> None:
        """Read the open project's objects in a worker on a read-only handle of its own (the window shows
        the pair meanwhile; every view of the objects hears ``objects_reset`` when they arrive). Objects of
        a project closed or replaced meanwhile are dropped; when the read fails or is cancelled the objects
        are read here instead (the window waits for them: the views never stay waiting for objects)."""
        ws = self.workspace
        cache = ws.cache
        if not cache.loading:
            return
        release_long_lived()  # the previous survey's objects, frozen when they arrived
        location = project_location(cache.project)

        def job(progress, cancelled):
            read = read_stored_objects(location, cancelled)
            if read is None:
                raise Cancelled
            return read

        def read_here(*_: object) -> None:
            if cache is not ws.cache or not cache.loading:
                return
            self.show_message("info", "reading the objects here (the window waits)")
            try:
                cache.reload()
            except UsvipsError as error:  # none shown (read again when the store is back: a live change)
                self.show_message("error", f"the objects cannot be read: {error}")
                if self.panels.is_built("objects"):
                    self.object_list.reading.hide()  # the views stay as the project's opening left them: empty

        def arrived(read: object) -> None:
            if ws.objects_arrived(cache, read):
                keep_long_lived()  # a survey's objects: no later collection on this thread scans them again

        worker = self.run_worker(job, "reading the objects", arrived, read_here)
        worker.signals.failed.connect(read_here)

    def forget_pair_loading(self) -> None:
        """A pair still being read is no longer wanted (another pair, or a video's frames, were asked for
        since): it is not shown when it arrives."""
        if self._pair_worker is not None:
            self._pair_worker.cancel()
            self._pair_worker = None

    # ------------------------------------------------------------------ workers
    @property
    def busy(self) -> bool:
        return self.jobs.busy

    def run_worker(self, job, label: str, on_done, on_cancelled=None) -> Worker:
        """Run ``job`` off the GUI thread (:meth:`usvips.gui.qt.jobs.Jobs.run`), its progress in the status bar."""
        return self.jobs.run(job, label, on_done, on_cancelled)

    def _on_work_started(self, label: str) -> None:
        self.progress.setRange(0, 0)
        self.progress.setFormat(label)
        self.progress.show()
        self.cancel_button.show()

    def _on_work_ended(self) -> None:
        self.progress.hide()
        self.cancel_button.hide()

    def cancel_work(self) -> None:
        self.jobs.cancel_all()

    # ------------------------------------------------------------------ display
    def refresh_pair_box(self) -> None:
        """The pair box lists the project's image pairs and shows the pair the model shows: an image pair
        by its label, a video's frame pair as "(video)" (its placeholder), nothing with no project."""
        labels = self.workspace.image_pairs()
        box = self.pair_box
        if [box.itemText(i) for i in range(box.count())] != labels:
            box.clear()
            box.addItems(labels)
        shown = self.workspace.pair
        placeholder = "(video)" if shown is not None and shown not in labels else ""
        if placeholder != box.placeholderText():
            box.setPlaceholderText(placeholder)
            box.update()  # Qt repaints nothing when an empty box's placeholder is cleared: "(video)" stayed
        box.setCurrentIndex(labels.index(shown) if shown in labels else -1)

    def _later(self, call: Callable[[], None]) -> None:
        """Run ``call`` once the events pending are handled (the overlay's next slice; one at a time)."""
        self._next_slice = call
        self._slice_timer.start()

    def _run_slice(self) -> None:
        call, self._next_slice = self._next_slice, None
        if call is not None:
            call()

    def _on_pair_changed(self) -> None:
        ws = self.workspace
        self.refresh_pair_box()  # the box follows the model (a video's frames or an image pair)
        if ws.project is not None and ws.pair is not None:  # where to come back to in this project
            self.settings.setValue(f"pair/{ws.project.path}", ws.pair)
            self.settings.setValue(f"frame/{ws.project.path}", -1 if ws.video_frame is None else ws.video_frame[1])
        if ws.pair is None:  # no pair shown (another project): nothing of the last one stays on the panes
            for side in SIDES:
                self.panes[side].title.setText(side.capitalize())
                self.panes[side].set_image(None)
            self.pixel_label.setText("")
            return
        for side in SIDES:
            self.panes[side].title.setText(pane_title(side, ws.pair, ws.images[side].shape, ws.video_frame))
            self._refresh_display(side)
        self._draw_control()
        if not isinstance(QtWidgets.QApplication.focusWidget(), (QtWidgets.QLineEdit, QtWidgets.QAbstractItemView)):
            self.focus_images()

    def _draw_control(self) -> None:
        """The pair's measured control points (any role), green with their numbers, on both images."""
        marks: dict[str, dict[str, tuple[float, float]]] = {side: {} for side in SIDES}
        ws = self.workspace
        if ws.project is not None and ws.pair is not None:
            for role in ("calibration-air", "calibration-water", "check"):
                stored = ws.project.control_observations(role, ws.pair)
                for i, pid in enumerate(stored.ids):
                    marks["left"][pid] = tuple(stored.left[i])
                    marks["right"][pid] = tuple(stored.right[i])
        for side in SIDES:
            self.panes[side].set_control(list(marks[side].items()))

    def _on_enhancement_changed(self, side: str) -> None:
        self._refresh_display(side)

    def _refresh_display(self, side: str) -> None:
        """Show the original at once, or the enhanced image computed in a worker (newest request wins);
        the histograms (original and shown) come with it."""
        ws = self.workspace
        original = ws.images.get(side)
        if original is None:
            return
        pipeline = ws.enhancement.pipelines[side]
        self._display_tokens[side] += 1
        token = self._display_tokens[side]
        if not pipeline.operations:
            counts = luminance_histogram(original)
            self._show_display(side, token, (original, counts, counts))
            return

        def job(progress, cancelled):
            display = pipeline.apply(original)
            return display, luminance_histogram(original), luminance_histogram(display)

        self.run_worker(job, f"enhancing the {side} image", lambda result: self._show_display(side, token, result))

    def _show_display(self, side: str, token: int, result: tuple) -> None:
        display, original_counts, shown_counts = result
        if token != self._display_tokens[side]:
            return  # a newer enhancement is on its way
        self.panes[side].set_image(display)
        if side == self.enhancement._sides()[0]:
            self.enhancement.show_histograms(original_counts, shown_counts)

    def each_pane(self, method: str, *args) -> None:
        for pane in self.panes.values():
            getattr(pane, method)(*args)

    def apply_box_zoom(self) -> None:
        self.each_pane("set_box_zoom", self.actions["box"].isChecked())

    def apply_link(self) -> None:
        """Linked navigation: zooming or panning one pane brings the other to the conjugate region (through
        the calibration, at the depth of the last measured point), at the same zoom."""
        if not hasattr(self, "_following"):
            self._following = False
            for side in SIDES:
                self.panes[side].range_changed.connect(lambda s=side: self._follow(s))
        if self.actions["link"].isChecked():
            self._follow("left")

    def _follow(self, side: str) -> None:
        if self._following or not self.actions["link"].isChecked() or self.workspace.pair is None:
            return
        source, target = self.panes[side], self.panes["right" if side == "left" else "left"]
        if source.display is None or target.display is None:
            return
        rect = source.view_rect()
        centre = pixel_from_item(rect.center().x(), rect.center().y())
        try:
            conjugate = self.workspace.pick_tool.conjugate(side, centre)
        except UsvipsError:
            conjugate = None
        self._following = True
        try:
            target.zoom_to(source.zoom_level(), conjugate or centre)  # no calibration: the same pixel
        finally:
            self._following = False

    def apply_loupe(self) -> None:
        for pane in self.panes.values():
            pane.set_loupe_enabled(self.actions["loupe"].isChecked())

    # ------------------------------------------------------------------ picking and measuring
    def _on_clicked(self, side: str, x: float, y: float) -> None:
        self._guarded(self.workspace.pick_tool.pick, side, (x, y))

    def _on_hovered(self, side: str, x: float, y: float) -> None:
        image = self.workspace.images.get(side)
        if image is None or not np.isfinite(x):
            self.pixel_label.setText("")
            return
        column, row = int(round(x)), int(round(y))
        value = image[row, column]
        grey = f"{int(value)}" if np.ndim(value) == 0 else "/".join(str(int(v)) for v in value)
        self.pixel_label.setText(f"{side}  x {x:8.2f}  y {y:8.2f}  value {grey}")

    def set_tool(self, tool: str) -> None:
        if self._guarded(self.workspace.pick_tool.set_tool, tool):
            self.actions[f"tool_{tool}"].setChecked(True)
            self.statusBar().showMessage(TOOL_TIPS[tool], 10000)

    def accept_or_finish(self) -> None:
        """Enter on the images: accept the proposed match; with a first pick but no proposal, say why and
        what to do; with no pick, finish the object being digitised."""
        state = self.workspace.pick_tool.state
        if state.proposal is not None or state.pending is not None:
            self._guarded(self.workspace.pick_tool.accept_proposal)
        elif state.source is not None:
            opposite = "right" if state.source == "left" else "left"
            self.show_message("warning", f"no proposed match to accept: click the point in the {opposite} image"
                                         + (f" ({state.note})" if state.note else ""))
        elif self.workspace.pick_tool.digitising.vertices:
            self.finish_object()
        else:
            self.show_message("warning", "nothing to accept: pick a point first")

    def finish_object(self) -> None:
        attribute = self.attribute_box.currentText().strip()
        if self._guarded(self.workspace.pick_tool.finish_object, attribute, ""):
            if attribute and self.attribute_box.findText(attribute) < 0:
                self.attribute_box.addItem(attribute)

    def cancel_pick(self) -> None:
        self.workspace.pick_tool.cancel_vertex()

    def nudge(self, dx: float, dy: float) -> None:
        """Move the current pick by (dx, dy) image pixels (the proposal when there is one)."""
        try:
            text = self.workspace.pick_tool.nudge(dx, dy)
        except UsvipsError as error:
            self.show_message("warning", str(error))
            return
        self.statusBar().showMessage(text, 10000)

    def step_pair(self, step: int) -> None:
        """Show the next (``step`` = 1) or previous (-1) image pair of the project."""
        labels = self.workspace.image_pairs()
        if not labels:
            self.show_message("warning", "no image pairs: open a project with images first")
            return
        current = labels.index(self.workspace.pair) if self.workspace.pair in labels else -step
        index = current + step
        if not 0 <= index < len(labels):
            self.show_message("info", f"{'last' if step > 0 else 'first'} pair reached ({labels[current]})")
            return
        if self.workspace.pick_tool.digitising.vertices:
            self.show_message("warning", "finish (Ctrl+Enter) or cancel the object being digitised before "
                                         "changing pairs")
            return
        self.load_pair(labels[index])

    def set_loupe_scale(self, scale: int) -> None:
        for pane in self.panes.values():
            pane.set_loupe_scale(scale)
        self.actions[f"loupe_{scale}"].setChecked(True)

    def _on_attribute_changed(self, text: str) -> None:
        self.workspace.pick_tool.attribute = text.strip()

    def _on_attribute_entered(self) -> None:
        """Enter in the Attribute box: keep the text for the next stored objects (and in the project's
        vocabulary), then give the keyboard back to the images."""
        text = self.attribute_box.currentText().strip()
        self.workspace.pick_tool.attribute = text
        if text and self.workspace.project is not None:
            self.workspace.project.add_term(text)
            if self.attribute_box.findText(text) < 0:
                self.attribute_box.addItem(text)
            self.attribute_box.setCurrentText(text)
        self.show_message("info", f"attribute of the next objects: {text!r}" if text else
                                  "the next objects are stored without an attribute")
        self.focus_images()

    def _on_observation_finished(self) -> None:
        """The record stored or skipped: the panel it was raised over is in front again, the images have
        the keyboard."""
        front, self._front_before_observation = self._front_before_observation, None
        if front is not None:
            front.raise_()
        self.focus_images()

    def focus_images(self, side: str = "left") -> None:
        """Give the keyboard to an image pane (Enter, Esc, nudging and Page Up/Down then work)."""
        self.panes[side].graphics.setFocus(QtCore.Qt.FocusReason.OtherFocusReason)

    def _on_project_changed(self, project) -> None:
        """Another project (or none): the window's own readouts forget the previous one (the panes, the
        docks and the video controls listen to the models themselves)."""
        self.attribute_box.clear()
        if project is not None:
            self.attribute_box.addItems(project.vocabulary())
        self.attribute_box.setCurrentIndex(-1)
        self.attribute_box.setEditText("")  # no term preselected: the user chooses
        self.statusBar().setStyleSheet("")
        self.statusBar().clearMessage()
        self.set_hint("")

    def retry_unsaved_edits(self) -> None:
        """Edit › Retry unsaved edits: make the kept edits again (e.g. once the server is back)."""
        edits = self.workspace.edits
        if not edits.unsaved:
            self.show_message("info", "no unsaved edits")
            return
        saved = edits.retry_unsaved()
        left = len(edits.unsaved)
        self.show_message("warning" if left else "info", f"saved {plural(saved, 'kept edit')}"
                          + (f"; {plural(left, 'edit')} still not saved" if left else ""))

    def discard_unsaved_edits(self) -> None:
        """Edit › Discard unsaved edits: forget the kept edits (the objects stay as stored)."""
        dropped = self.workspace.edits.discard_unsaved()
        self.show_message("info", f"discarded {plural(dropped, 'unsaved edit')}" if dropped else "no unsaved edits")

    def undo(self) -> None:
        self._step("undo", "undone")

    def redo(self) -> None:
        self._step("redo", "redone")

    def _step(self, verb: str, done: str) -> None:
        try:
            label = getattr(self.workspace.undo, verb)()
        except UsvipsError as error:
            dropped = " — the step is dropped (nothing was changed)" if isinstance(error, StaleEditError) else ""
            self.show_message("error", f"cannot {verb}: {error}{dropped}")
            return
        if label:
            self.show_message("info", f"{done}: {label}")

    def _on_undo_changed(self) -> None:
        undo, redo = self.workspace.undo.undo_label, self.workspace.undo.redo_label
        self._update_enablement()
        # the toolbar keeps short names; what would be undone is in the tooltip and the status tip
        self.actions["undo"].setToolTip(f"Undo {undo} (Ctrl+Z)" if undo else "nothing to undo")
        self.actions["redo"].setToolTip(f"Redo {redo} (Ctrl+Shift+Z)" if redo else "nothing to redo")

    def apply_snap(self) -> None:
        self.workspace.settings.snap = self.actions["snap"].isChecked()

    def apply_auto_match(self) -> None:
        self.workspace.settings.auto_match = self.actions["auto_match"].isChecked()

    def _on_picks_changed(self) -> None:
        ws = self.workspace
        state = ws.pick_tool.state
        for side in SIDES:
            opposite = state.source is not None and state.source != side
            self.panes[side].set_picks(state.pick(side), state.proposal if opposite else None,
                                       state.curve if opposite else None, weak=state.weak)
            if opposite and state.proposal is not None:  # a match proposed off a zoomed view: seen before Enter
                self.panes[side].bring_into_view(state.proposal)
        if state.note:
            self.statusBar().showMessage(state.note, 15000)
            self.set_hint(state.note, "warning" if state.pending is not None or state.weak else "info")
        self.point_label.setText(describe_point(ws.pick_tool.last_point) if ws.pick_tool.last_point is not None else "")

    def _on_selection_changed(self, ids) -> None:
        """The model's selection (the geo-calculator, the plan and the panes follow it themselves)."""
        self.selection = list(ids)
        if len(ids) == 1:
            self.observation.load(ids[0])  # every stored object's record is editable

    def show_qa(self) -> None:
        """Ctrl+Shift+Q: show the QA panel and give it the keyboard."""
        self.docks["qa"].show()
        self.docks["qa"].raise_()
        self.qa.focus_list()

    def show_instants(self, object_id: int | None = None) -> bool:
        """I (images) or Ctrl+I (object list): the instants of ``object_id`` (default: the one selected)."""
        ids = [object_id] if object_id is not None else list(self.workspace.selection)
        if len(ids) != 1:
            self.show_message("warning", "select one object to list its instants")
            return False
        shown = self.instants_view.show_object(ids[0])
        self.instants_view.show()
        self.instants_view.raise_()
        self.instants_view.table.setFocus()
        return shown

    def show_double_read(self):
        """File › Double-read report…: the dialog (imported here: its matching needs scipy.optimize, which
        showing a pair does not)."""
        from usvips.gui.qt import double_read_dialog

        return double_read_dialog.show_double_read(self.context, self)

    def show_pointing_test(self):
        """Measure › Pointing test…: click rendered targets; your pointing σ, stored for you on request."""
        from usvips.gui.qt import pointing_test_dialog

        return pointing_test_dialog.show_pointing_test(self.context, self.annotator, self)

    def show_target_field_tool(self) -> None:
        """Calibration › Find a target field… (imported when first asked for: not at start-up)."""
        from usvips.gui.qt import target_field_tool

        tool = target_field_tool.open_tool(self.context, self)
        if tool is not None:
            self.target_field_tool = tool
            tool.confirmed.connect(lambda _text: self._draw_control())  # the pair's control drawn anew

    def show_sigma_check(self):
        """Measure › Check σ (Monte Carlo)…: whether the open project's stated σ hold (its own geometry)."""
        from usvips.gui.qt import pointing_test_dialog

        return pointing_test_dialog.show_sigma_check(self.context, self)

    def show_review(self) -> None:
        """Ctrl+Shift+R: show the review panel, its queue read afresh (the objects unreviewed now, also by
        other annotators), and give it the keyboard (N, P, A, F, S, J work there)."""
        self.docks["review"].show()
        self.docks["review"].raise_()
        self.review.load()
        self.object_list.reload_reviews()
        self.review.focus_queue()

    def title(self) -> str:
        """The title bar: the annotator, and the open project."""
        project = self.workspace.project
        if project is None:
            return f"USVIPS — {self.annotator}"
        path = project.path  # a survey on a server prints as host/database (its path is its media folder's)
        where = str(path) if str(path) != os.fspath(path) else f"{path.name} ({path.parent})"
        return f"USVIPS — {self.annotator} — {redact(where)} — every step is saved as you go"

    def annotator_dialog(self) -> None:
        """File › Annotator: your name…: ask the name (kept in the settings for the next sessions)."""
        dialog = AnnotatorDialog(self.annotator, self)
        if dialog.exec() == QtWidgets.QDialog.DialogCode.Accepted:
            self.set_annotator(dialog.name())

    def set_annotator(self, name: str) -> bool:
        """Work as ``name`` from now on: kept in the settings, shown in the title bar, and the annotator of
        the open project's writes. A name that cannot be used is said in one line and changes nothing."""
        try:
            self.annotator = save_annotator(self.settings, name)
        except UsvipsError as error:
            self.show_message("error", str(error))
            return False
        if self.workspace.project is not None:
            self.workspace.project.annotator = self.annotator
        self.setWindowTitle(self.title())
        self.show_message("info", f"annotating as {self.annotator}")
        return True

    def _on_object_requested(self, object_id: int) -> None:
        """A view asked for a stored object (``Workspace.request_object``, which selected it): the panes
        are centred on it once its pair or video frame is shown — an image pair is read here, a video's
        frame is the video controller's to show."""
        ws = self.workspace
        where = ws.place_of(object_id)
        if self._centre_pending is not None:  # an earlier request still waiting: this one wins
            ws.pair_changed.disconnect(self._centre_pending)
            self._centre_pending = None
        if where is None:
            return
        if where == ws.place():
            self.zoom_to_object(object_id)
            return
        pair, frame = where

        def centre_when_shown() -> None:  # on the pair (or frame) shown next; a video's frames on the way wait
            if ws.place() == where or frame is None or ws.pair != pair:
                ws.pair_changed.disconnect(centre_when_shown)
                self._centre_pending = None
                if ws.place() == where and object_id in ws.cache:
                    self.zoom_to_object(object_id)

        self._centre_pending = centre_when_shown
        ws.pair_changed.connect(centre_when_shown)
        if frame is None:
            self.load_pair(pair)

    def zoom_to_object(self, object_id: int) -> None:
        stored = self.workspace.stored_object(object_id)
        here = self.workspace.place()
        vertices = [v for v in stored.vertices if (v.pair, None if v.video is None else int(v.frame_left)) == here]
        if not vertices:
            self.show_message("warning", f"object {object_id} was measured on another pair")
            return
        for side, columns in (("left", ("xl", "yl")), ("right", ("xr", "yr"))):
            pixels = np.array([[getattr(v, c) for c in columns] for v in vertices])
            self.panes[side].centre_on(tuple(pixels.mean(axis=0)))
