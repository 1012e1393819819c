"""The workstation's model, free of Qt: the open project and the pair (or video frame pair) shown, composed
of one model per concern, each in its own module: the picking and measuring tool and its state machine
(:mod:`usvips.gui.pick_tool`), the stored objects and their figures (:mod:`usvips.gui.object_cache`), the
display enhancement (:mod:`usvips.gui.enhancement_model`), undo (:mod:`usvips.gui.undo`; one stack for
all). Opening a project makes NEW instances of the per-project ones (nothing of the previous project can
survive); their events belong to the workspace, so views connect once. The window only draws what these
hold and forwards clicks. Callers use the models through the workspace's fields (``workspace.pick_tool.pick``,
``workspace.cache.objects()``, ``workspace.edits.delete_object`` ...): the workspace forwards nothing
but what the pick tool and the edits need of their scene.

Pixels follow ARCHITECTURE.md: x right, y down, origin at the centre of the top-left pixel (float64).
3-D points are metres in the frame of the pair's calibration: the object frame when the pair is a
calibrated station, otherwise the rig frame (origin at the left camera's perspective centre).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from usvips.app.pair_geometry import PairGeometry, pair_geometry
from usvips.app.project_figures import measurement_input, place_text
from usvips.app.quality import species_maxima
from usvips.core.errors import UsvipsError
from usvips.core.measurements import QualityRules
from usvips.core.measurements import kind as measurement_kind
from usvips.gui.calculator import Result
from usvips.gui.enhancement_model import Enhancement
from usvips.gui.object_cache import ObjectCache, ObjectEvents, StoredObjects
from usvips.gui.object_edits import ObjectEdits
from usvips.gui.pick_tool import SIDES, PickEvents, PickSettings, PickTool
from usvips.gui.signals import Signal
from usvips.gui.undo import UndoStack
from usvips.io.images import read_image
from usvips.store.interface import ProjectStore


def pair_image_paths(project: ProjectStore, label: str) -> tuple[Path, Path]:
    """The absolute paths of a pair's two images (raises when the pair has none or a file is missing)."""
    pair = next((p for p in project.pairs() if p.label == label), None)
    if pair is None:
        raise UsvipsError(f"{project.path}: no image pair {label!r}")
    if not pair.left or not pair.right:
        raise UsvipsError(f"pair {label!r} has no images (observations only)")
    return project.image_path(pair.left), project.image_path(pair.right)


def read_pair(paths: tuple[Path, Path]) -> tuple[np.ndarray, np.ndarray]:
    """Read a pair's two images (may take a while for large ones: the window calls it off the GUI thread;
    the project itself stays on the GUI thread, SQLite connections are not shared between threads)."""
    return read_image(paths[0]), read_image(paths[1])


def load_pair_images(project: ProjectStore, label: str) -> tuple[np.ndarray, np.ndarray]:
    """Both steps at once, for scripts and tests."""
    return read_pair(pair_image_paths(project, label))


@dataclass
class Workspace:
    """The open project, the current pair with its images and calibration, composing the models.

    Events (:class:`Signal`), each saying what changed so that a view redraws just that:

    - ``pair_changed()``; ``tool_changed(tool)``; ``picks_changed()`` (the pick state, the object being
      digitised or the last measured point changed); ``enhancement_changed(side)``;
    - ``objects_added(ids)``, ``objects_updated(ids)``, ``objects_removed(ids)`` (tuples of object ids,
      after the model's cache of the stored objects holds the change), ``objects_reset()`` (another
      project: every object is new), and ``objects_changed()`` after any of these, for views that only
      recount (the video timeline's marks);
    - ``project_changed(project)`` (another project, or None: every per-project model is new; views
      forget what they showed of the previous one), after the events above have said what is gone;
    - ``selection_changed(ids)``; ``rules_changed(rules)`` (the quality rules: every figure's verdict);
    - ``object_requested(object_id)``: a view asked to be shown an object (the object list's double-click
      or Zoom to, a QA row, an instant); the views that can show it listen (the video goes to its frame,
      the window to its pair) — never to each other;
    - ``message(level, text)`` with level ``info``, ``warning`` or ``error``, ``observed(left, right)``
      when the observe tool has both picks of a point, ``stored(object_id)`` after a new object.

    The stored objects are read from the project by ONE query when a project opens and then kept here,
    updated by id as they change (:meth:`objects`, :meth:`stored_object`); each object's figures are
    computed once per change of the object or the rules (:meth:`object_figures`).
    """

    project: ProjectStore | None = None
    rules: QualityRules = field(default_factory=QualityRules)
    #: the pick tool's settings (snap, auto-match, curve depths, off-curve limit): kept across projects
    settings: PickSettings = field(default_factory=PickSettings)

    def __post_init__(self) -> None:
        self.pair: str | None = None
        self.images: dict[str, np.ndarray] = {}
        self.geometry: PairGeometry | None = None
        self.video_frame: tuple[str, int, int, float] | None = None  # video, left and right frame, time (s)
        self.undo = UndoStack()
        self.enhancement_changed = Signal()
        self.message = Signal()
        #: the display enhancement of the two images (usvips.gui.enhancement_model)
        self.enhancement = Enhancement(self.undo, self.enhancement_changed, self.message)
        self.pair_changed = Signal()
        self.project_changed = Signal()
        #: the pick tool's events; each project's new PickTool announces through these
        self.pick_events = PickEvents()
        self.picks_changed = self.pick_events.picks_changed
        self.tool_changed = self.pick_events.tool_changed
        self.observed = self.pick_events.observed
        #: ``stored(object_id)`` after a newly measured object is stored (its observation record may follow).
        self.stored = self.pick_events.stored
        #: the picking and measuring tool (usvips.gui.pick_tool), a new one per project
        self.pick_tool = PickTool(self, self.pick_events, self.settings)
        #: the undoable edits of stored objects (usvips.gui.object_edits; they hold nothing per project)
        self.edits = ObjectEdits(self, lambda: self.pick_tool.clear_state())
        #: the stored objects' events; each project's new ObjectCache announces through these
        self.object_events = ObjectEvents()
        self.objects_changed = self.object_events.changed
        self.objects_added = self.object_events.added
        self.objects_updated = self.object_events.updated
        self.objects_removed = self.object_events.removed
        self.objects_reset = self.object_events.reset
        self.cache = ObjectCache(None, self.object_events, lambda: self.rules)
        self.selection_changed = Signal()
        self.rules_changed = Signal()
        self.object_requested = Signal()
        #: The selected objects' ids (the object list and the geo-calculator show them).
        self.selection: tuple[int, ...] = ()

    # ------------------------------------------------------------------ project and pair
    def open_project(self, project: ProjectStore, deferred: bool = False) -> None:
        """Start afresh on ``project``; ``deferred``: its objects are not read here, the cache is empty and
        ``loading`` until :meth:`objects_arrived` is handed them (read off the GUI thread,
        :func:`usvips.gui.object_cache.read_stored_objects`)."""
        self._switch_project(project, deferred)

    def objects_arrived(self, cache: ObjectCache, read: StoredObjects) -> bool:
        """The objects read for ``cache`` held and announced (``objects_reset``); False (nothing done) when
        ``cache`` is no longer this workspace's (another project opened, or this one closed, meanwhile)."""
        if cache is not self.cache:
            return False
        cache.arrived(read)
        return True

    def close_project(self) -> None:
        self._switch_project(None)

    def _switch_project(self, project: ProjectStore | None, deferred: bool = False) -> None:
        """Close the open project (unless it is ``project``) and start afresh on ``project``: new models
        for it (object cache, enhancement, pick tool: nothing of the previous project can survive)."""
        if self.project is not None and self.project is not project:
            self.project.close()
        self.project = project
        self.cache = ObjectCache(project, self.object_events, lambda: self.rules, deferred)
        self.pair, self.images, self.geometry, self.video_frame = None, {}, None, None
        self.enhancement = Enhancement(self.undo, self.enhancement_changed, self.message)
        self.pick_tool = PickTool(self, self.pick_events, self.settings, tool=self.pick_tool.tool)
        self.undo.clear()
        self.selection = ()
        self.objects_reset.emit()
        self.objects_changed.emit()
        self.selection_changed.emit(self.selection)
        self.picks_changed.emit()
        self.pair_changed.emit()
        self.project_changed.emit(project)

    def _shared(self, geometry: PairGeometry | None) -> PairGeometry | None:
        """``geometry`` with the very calibration object the stored objects' figures use (read once per
        project): what is kept per calibration for the picks (the stepped cameras, a vertex's derivatives)
        then serves the figures of the object stored from them."""
        if geometry is None:
            return None
        known = self.cache.calibrations.get(geometry.calibration_id)
        if known is None:
            self.cache.calibrations[geometry.calibration_id] = geometry.calibration
            return geometry
        return replace(geometry, calibration=known)

    def image_pairs(self) -> list[str]:
        """Labels of the project's pairs that have images."""
        if self.project is None:
            return []
        return [p.label for p in self.project.pairs() if p.left and p.right]

    def reshow_pair(self) -> None:
        """Show the current pair again, its images kept, so that a calibration made active for it since is
        used (nothing when no pair is shown)."""
        if self.pair is not None and self.images:
            self.set_pair(self.pair, self.images["left"], self.images["right"], self.video_frame)

    def set_pair(self, label: str, left: np.ndarray, right: np.ndarray,
                 video_frame: tuple[str, int, int, float] | None = None) -> None:
        """Show a pair (images already read, see :func:`load_pair_images`); its calibration and saved
        enhancements come from the project. ``video_frame``: (video, left frame, right frame, time s) when
        the images are a video's frame pair — known before ``pair_changed`` fires, so that every view
        draws the objects of that frame at once."""
        if self.project is None:
            raise UsvipsError("open a project first")
        another_pair, self.pair = label != self.pair, label
        self.video_frame = video_frame
        what = "video" if video_frame is not None else "pair"  # a video's frames are not "pair 'dive1'"
        self.images = {"left": left, "right": right}
        try:
            self.geometry = self._shared(pair_geometry(self.project, label))
        except UsvipsError as error:
            self.geometry = None
            self.message.emit("error", f"the calibration of {what} {label!r} cannot be used: {error}")
        self.enhancement.load(self.project, {side: self.image_key(side) for side in SIDES})
        self.pick_tool.reset()
        self.undo.forget_pair_steps()  # the picks and enhancement steps go with their images; object steps stay
        self.pair_changed.emit()
        if not another_pair:
            return  # the next frame of a video, or the pair shown again: its frame rule was said
        if self.geometry is None:
            self.message.emit("warning", f"{what} {label!r} has no active calibration: picks are shown, "
                                         "nothing can be intersected")
        else:
            named = f"video {label!r}" if video_frame is not None else f"pair {label}"  # not "video video:"
            self.message.emit("info", f"{named}: {self.geometry.description}")

    def image_key(self, side: str) -> str:
        """The project's key for an image's settings: its stored relative path."""
        pair = next(p for p in self.project.pairs() if p.label == self.pair)
        return str(getattr(pair, side))

    # ------------------------------------------------------------ the scene of the pick tool and the edits
    # (usvips.gui.pick_tool.PickScene, usvips.gui.object_edits.EditScene): what they need of the workspace.
    # Everything else of the models is read from the fields: ``pick_tool`` (the tool, its state, the object
    # being digitised), ``cache`` (the stored objects and their figures), ``edits`` (undoable edits of stored
    # objects), ``enhancement`` (the display enhancement), ``settings`` (snap, auto-match).
    def edit_stored(self, label: str, object_id: int, edit: Callable[[str], None],
                    then: Callable[[], None] | None = None) -> None:
        """Run ``edit(version read)`` of a stored object as one undoable command restoring its rows exactly."""
        self.edits.edit_stored(label, object_id, edit, then)

    def frame_description(self, object_id: int) -> str:
        """The frame an object's coordinates (and so its bearing and slope) are given in, in words."""
        stored = self.stored_object(object_id)
        g = measurement_input(self.project, stored, self.cache.calibrations)
        if g.calibration is None:
            return "the frame it was measured in (its calibration is no longer in the project)"
        if g.frame == "object":
            return f"the object frame of station {g.station} (the control points' axes)"
        return "the rig frame (origin at the left camera; X right, Y up, the camera looking along −Z)"

    def stored_object(self, object_id: int):
        """One stored object from the cache (raises by name when there is none)."""
        return self.cache.get(object_id)

    def figures(self, object_ids: list[int]) -> Result:
        """The geo-calculator on a selection of one or two objects (one object's figures are computed once
        per change and kept)."""
        return self.cache.figures(object_ids)

    # ------------------------------------------------------------------ the stored objects and the selection
    def species_maxima(self) -> dict:
        """The project's species list by name, for the one verdict's species rule (read when asked: a list
        imported meanwhile counts at once); {} without a project."""
        return species_maxima(self.project.species_list()) if self.project is not None else {}

    def objects_changed_in_store(self, added: tuple[int, ...] = (), updated: tuple[int, ...] = (),
                                  removed: tuple[int, ...] = ()) -> None:
        """The cache brought up to date with what was just written (announced by id); the selection
        drops the objects gone."""
        gone = self.cache.changed_in_store(added, updated, removed)
        if set(gone) & set(self.selection):
            self.select([i for i in self.selection if i not in gone])

    def show_as_cached(self, object_ids: tuple[int, ...]) -> None:
        """Announce objects as the cache holds them, reading nothing (a save that failed: the views show
        them as stored again, e.g. the object list's cell reverts)."""
        present = tuple(i for i in object_ids if i in self.cache)
        if present:
            self.cache.events.updated.emit(present)

    def reload_objects(self) -> None:
        """Read every stored object again (by one query), e.g. after another program changed the project."""
        self.cache.reload()
        self.select(self.selection)

    def select(self, object_ids) -> None:
        """Make ``object_ids`` the selection (ids not stored are left out); announced when it changes."""
        selection = tuple(int(i) for i in object_ids if int(i) in self.cache)
        if selection != self.selection:
            self.selection = selection
            self.selection_changed.emit(selection)

    def request_object(self, object_id: int) -> bool:
        """Ask the views to show a stored object, selected: it is selected, then announced as
        ``object_requested`` (the video goes to its frame, the window to its pair, centred on it). Said,
        not announced (False): an id not stored, or an object on another image pair while one is being
        digitised here (finish or cancel that first: going away would leave it half measured)."""
        object_id = int(object_id)
        if object_id not in self.cache:
            self.message.emit("warning", f"object {object_id} is no longer in the project")
            return False
        where = self.place_of(object_id)
        if where is not None and where != self.place() and self.pick_tool.digitising.vertices:
            pair, frame = where
            shown = place_text(pair, frame)
            self.message.emit("warning", f"object {object_id} is on {shown}: finish (Ctrl+Enter) or cancel "
                                         "the object being digitised first")
            return False
        self.select([object_id])
        self.object_requested.emit(object_id)
        return True

    def place(self) -> tuple[str | None, int | None]:
        """Where picks are made now: (the pair shown, the left frame when it is a video's frame pair)."""
        return self.pair, None if self.video_frame is None else int(self.video_frame[1])

    def place_of(self, object_id: int) -> tuple[str, int | None] | None:
        """Where a stored object was measured, as :meth:`place` says it (its first vertex: the pair — a
        video's label for a video — and the left frame on a video); None for an object without one."""
        stored = self.stored_object(object_id)
        first = stored.vertices[0] if stored.vertices else None
        if first is None or first.pair is None:
            return None
        return first.pair, None if first.video is None else int(first.frame_left)

    def set_rules(self, rules: QualityRules) -> None:
        """New quality rules: every object's verdict may change (its figures are computed again)."""
        if rules == self.rules:
            return
        self.rules = rules
        self.cache.forget_figures()
        self.rules_changed.emit(rules)

    def pointing_changed(self) -> None:
        """The project's pointing estimates in use changed (:mod:`usvips.app.pointing_settings`): every
        figure's σ may change, as under new rules — its figures are computed again and the views that
        follow the rules (object list, QA panel, calculator) recompute."""
        self.cache.forget_figures()
        self.rules_changed.emit(self.rules)

    def vertices_shown(self, stored) -> list:
        """The stored object's vertices measured on the current pair and, on a video, on the frame shown."""
        return [v for v in stored.vertices if v.pair == self.pair
                and (self.video_frame is None or v.frame_left == self.video_frame[1])]

    def outline(self, stored) -> tuple[np.ndarray, np.ndarray, bool] | None:
        """How a stored object is drawn on the current pair: pixels (M, 2) on the left and right image and
        whether the outline closes; None when it was measured on another pair. Markers, polylines and
        polygons go through the picks; a circle is its fitted 3-D circle projected through the pair's
        calibration (an ellipse in the image), or the polygon of its picks when it cannot be projected."""
        vertices = self.vertices_shown(stored)
        if not vertices:
            return None
        left = np.array([[v.xl, v.yl] for v in vertices])
        right = np.array([[v.xr, v.yr] for v in vertices])
        try:
            k = measurement_kind(stored.kind)
        except UsvipsError:
            return left, right, False
        if k.drawing == "circle" and self.geometry is not None and all(v.xyz is not None for v in vertices):
            try:
                ring = k.outline(np.array([v.xyz for v in vertices], float))
                rig = self.geometry.calibration.rig(self.geometry.station, self.geometry.frame)
                projected = [rig.left.project(ring), rig.right.project(ring)]
                if all(p.ok.all() for p in projected):
                    return projected[0].pixels, projected[1].pixels, False
            except UsvipsError:
                pass
        return left, right, k.closes

