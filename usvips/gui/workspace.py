"""The workstation's model, free of Qt: the open project and the pair (or video frame pair) shown, and the
picking and measuring tool (its state machine; every step a command on one undo stack). It is made of one
model per concern, each in its own module: the stored objects and their figures
(:mod:`usvips.gui.object_cache`), the display enhancement (:mod:`usvips.gui.enhancement_model`), undo
(:mod:`usvips.gui.undo`). Opening a project makes NEW instances of the per-project ones (nothing of the
previous project can survive); their events belong to the workspace, so views connect once. The window
only draws what these hold and forwards clicks.

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
from usvips.app.project_figures import measurement_input
from usvips.core.enhance import Pipeline
from usvips.core.errors import DegenerateGeometryError, UsvipsError
from usvips.core.matching import EpipolarCurve, epipolar_curve, match_along_curve
from usvips.core.measurements import QualityRules, intersect_vertices, names, registered_kinds, resolve
from usvips.core.measurements import kind as measurement_kind
from usvips.core.observation_record import ObservationRecord
from usvips.core.stereo_calibration import StereoCalibration
from usvips.core.targets import locate_disc
from usvips.gui.calculator import Result, format_figure, vertex_failures
from usvips.gui.enhancement_model import Enhancement
from usvips.gui.object_cache import ObjectCache, ObjectEvents
from usvips.gui.signals import Signal
from usvips.gui.undo import Command, UndoStack
from usvips.gui.wording import article, plural
from usvips.io.images import read_image
from usvips.store.interface import ProjectStore
from usvips.store.project import Vertex

SIDES = ("left", "right")
#: The "line" tool digitises a polyline stored as the kind the registry's legacy rule makes of it
#: (``length`` with two vertices, a fish; ``arc`` with more), so no separate length tool; every other
#: registered measurement kind is a tool of its own (a new kind appears here by itself).
LINE = "line"
TOOLS = ("pick", "point", LINE, "polygon") + tuple(n for n in names() if n not in ("point", "polygon", "length"))
#: The calibration wizards' tool: both picks of a control point, reported by ``observed``, not intersected.
OBSERVE = "observe"
#: Depth (m along the ray in the water) linked navigation assumes before anything has been measured.
LINK_DEPTH_M = 2.0


def other(side: str) -> str:
    return "right" if side == "left" else "left"


@dataclass(frozen=True)
class PickState:
    """The vertex being digitised: its picks (pixels), the epipolar curve drawn in the image opposite
    ``source`` (the side picked first), the auto-match ``proposal`` there (``weak`` when auto-match
    refused it but it is the best candidate on the curve: drawn apart, accepted by Enter all the same),
    and a note for the user."""

    left: tuple[float, float] | None = None
    right: tuple[float, float] | None = None
    source: str | None = None
    curve: np.ndarray | None = None
    proposal: tuple[float, float] | None = None
    note: str = ""
    weak: bool = False
    #: A vertex intersected from both picks but held back by a guard rail until the user keeps it (Enter).
    pending: MeasuredVertex | None = None

    def pick(self, side: str) -> tuple[float, float] | None:
        return self.left if side == "left" else self.right


@dataclass(frozen=True)
class MeasuredVertex:
    """A vertex with both picks intersected: X, Y, Z (m), its 3 × 3 covariance (m²), the distance of the
    point from the rays (m, RMS) and its range from the left camera (m)."""

    left: tuple[float, float]
    right: tuple[float, float]
    xyz: np.ndarray
    covariance: np.ndarray
    ray_rms_m: float
    range_m: float
    #: Guard-rail warnings the user overrode when keeping this vertex (stored with the object's notes).
    flags: tuple[str, ...] = ()

    @property
    def sigmas(self) -> np.ndarray:
        return np.sqrt(np.clip(np.diag(self.covariance), 0, None))


def pair_image_paths(project: ProjectStore, label: str) -> tuple[Path, Path]:
    """The absolute paths of a pair's two images (raises when the pair has none or a file is missing)."""
    pair = next((p for p in project.pairs() if p["label"] == label), None)
    if pair is None:
        raise UsvipsError(f"{project.path}: no image pair {label!r}")
    if not pair["left"] or not pair["right"]:
        raise UsvipsError(f"pair {label!r} has no images (observations only)")
    return project.image_path(pair["left"]), project.image_path(pair["right"])


def read_pair(paths: tuple[Path, Path]) -> tuple[np.ndarray, np.ndarray]:
    """Read a pair's two images (may take a while for large ones: the window calls it off the GUI thread;
    the project itself stays on the GUI thread, SQLite connections are not shared between threads)."""
    return read_image(paths[0]), read_image(paths[1])


def load_pair_images(project: ProjectStore, label: str) -> tuple[np.ndarray, np.ndarray]:
    """Both steps at once, for scripts and tests."""
    return read_pair(pair_image_paths(project, label))


@dataclass
class _Digitising:
    """The object being digitised: its kind and the vertices measured so far."""

    kind: str
    vertices: tuple[MeasuredVertex, ...] = ()


@dataclass
class Workspace:
    """The open project, the current pair with its images and calibration, the tool and its state.

    Events (:class:`Signal`), each saying what changed so that a view redraws just that:

    - ``pair_changed()``; ``tool_changed(tool)``; ``picks_changed()`` (the pick state, the object being
      digitised or the last measured point changed); ``enhancement_changed(side)``;
    - ``objects_added(ids)``, ``objects_updated(ids)``, ``objects_removed(ids)`` (tuples of object ids,
      after the model's cache of the stored objects holds the change), ``objects_reset()`` (another
      project: every object is new), and ``objects_changed()`` after any of these, for views that only
      recount (the video timeline's marks);
    - ``selection_changed(ids)``; ``rules_changed(rules)`` (the quality rules: every figure's verdict);
    - ``message(level, text)`` with level ``info``, ``warning`` or ``error``, ``observed(left, right)``
      when the observe tool has both picks of a point, ``stored(object_id)`` after a new object.

    The stored objects are read from the project by ONE query when a project opens and then kept here,
    updated by id as they change (:meth:`objects`, :meth:`stored_object`); each object's figures are
    computed once per change of the object or the rules (:meth:`object_figures`).
    """

    project: ProjectStore | None = None
    snap: bool = False
    auto_match: bool = True
    rules: QualityRules = field(default_factory=QualityRules)
    near_m: float = 0.2
    far_m: float = 20.0
    #: A second pick farther than this (pixels) from the first pick's epipolar curve is held for a check.
    max_off_curve_px: float = 5.0

    def __post_init__(self) -> None:
        self.pair: str | None = None
        self.images: dict[str, np.ndarray] = {}
        self.geometry: PairGeometry | None = None
        self.state = PickState()
        self.digitising: _Digitising = _Digitising("pick")
        self.last_point: MeasuredVertex | None = None
        #: The attribute given to the next stored object (the window's Attribute box keeps it current).
        self.attribute = ""
        #: (object id, vertex index from 0) that the next measured vertex replaces, or None.
        self.repick: tuple[int, int] | None = None
        self.undo = UndoStack()
        self.enhancement_changed = Signal()
        self.message = Signal()
        #: the display enhancement of the two images (usvips.gui.enhancement_model)
        self.enhancement = Enhancement(self.undo, self.enhancement_changed, self.message)
        self.pair_changed = Signal()
        self.picks_changed = Signal()
        #: the stored objects' events; each project's new ObjectCache announces through these
        self.object_events = ObjectEvents()
        self.objects_changed = self.object_events.changed
        self.objects_added = self.object_events.added
        self.objects_updated = self.object_events.updated
        self.objects_removed = self.object_events.removed
        self.objects_reset = self.object_events.reset
        self.cache = ObjectCache(None, self.object_events, lambda: self.rules)
        self.tool_changed = Signal()
        self.selection_changed = Signal()
        self.rules_changed = Signal()
        #: The selected objects' ids (the object list and the geo-calculator show them).
        self.selection: tuple[int, ...] = ()
        self.observed = Signal()
        self.video_frame: tuple[str, int, int, float] | None = None  # video, left and right frame, time (s)
        #: ``stored(object_id)`` after a newly measured object is stored (its observation record may follow).
        self.stored = Signal()

    # ------------------------------------------------------------------ project and pair
    def open_project(self, project: ProjectStore) -> None:
        self._switch_project(project)

    def close_project(self) -> None:
        self._switch_project(None)

    def _switch_project(self, project: ProjectStore | None) -> None:
        """Close the open project (unless it is ``project``) and start afresh on ``project``."""
        if self.project is not None and self.project is not project:
            self.project.close()
        self.project = project
        self.cache = ObjectCache(project, self.object_events, lambda: self.rules)  # new: nothing survives
        self.attribute = ""
        self.last_point = None
        self.repick = None
        self.pair, self.images, self.geometry = None, {}, None
        self.enhancement = Enhancement(self.undo, self.enhancement_changed, self.message)  # new: nothing survives
        self._reset_picks()
        self.undo.clear()
        self.selection = ()
        self.objects_reset.emit()
        self.objects_changed.emit()
        self.selection_changed.emit(self.selection)
        self.pair_changed.emit()

    def _shared(self, geometry: PairGeometry | None) -> PairGeometry | None:
        """``geometry`` with the very calibration object the stored objects' figures use (read once per
        project): what is kept per calibration for the picks (the stepped cameras, a vertex's derivatives)
        then serves the figures of the object stored from them."""
        if geometry is None:
            return None
        known = self._calibrations.get(geometry.calibration_id)
        if known is None:
            self._calibrations[geometry.calibration_id] = geometry.calibration
            return geometry
        return replace(geometry, calibration=known)

    def image_pairs(self) -> list[str]:
        """Labels of the project's pairs that have images."""
        if self.project is None:
            return []
        return [p["label"] for p in self.project.pairs() if p["left"] and p["right"]]

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
        self.images = {"left": left, "right": right}
        try:
            self.geometry = self._shared(pair_geometry(self.project, label))
        except UsvipsError as error:
            self.geometry = None
            self.message.emit("error", f"the calibration of pair {label!r} cannot be used: {error}")
        self.enhancement.load(self.project, {side: self.image_key(side) for side in SIDES})
        self._reset_picks()
        self.undo.clear()
        self.pair_changed.emit()
        if not another_pair:
            return  # the next frame of a video, or the pair shown again: its frame rule was said
        if self.geometry is None:
            self.message.emit("warning", f"pair {label!r} has no active calibration: picks are shown, "
                                         "nothing can be intersected")
        else:
            self.message.emit("info", f"pair {label}: {self.geometry.description}")

    def image_key(self, side: str) -> str:
        """The project's key for an image's settings: its stored relative path."""
        pair = next(p for p in self.project.pairs() if p["label"] == self.pair)
        return str(pair[side])

    # ------------------------------------------------------------------ enhancement (usvips.gui.enhancement_model)
    @property
    def pipelines(self) -> dict[str, Pipeline]:
        return self.enhancement.pipelines

    def set_pipeline(self, side: str, pipeline: Pipeline) -> None:
        """Change an image's enhancement (display only: picks and coordinates use the original) and save
        it in the project; undoable."""
        self.enhancement.set_pipelines({side: pipeline})

    def set_pipelines(self, changes: dict[str, Pipeline]) -> None:
        """Change the enhancement of one or both images as one undoable step."""
        self.enhancement.set_pipelines(changes)

    # ------------------------------------------------------------------ tool
    @property
    def tool(self) -> str:
        return self.digitising.kind

    def set_tool(self, tool: str) -> None:
        if tool not in TOOLS + (OBSERVE,):
            raise UsvipsError(f"unknown tool {tool!r}; tools: {', '.join(TOOLS)}")
        if self.digitising.vertices:
            self.message.emit("warning", f"the unfinished {self.digitising.kind} "
                                         f"({plural(len(self.digitising.vertices), 'vertex')}) was dropped")
        self.digitising = _Digitising(tool)
        self._reset_picks()
        self.tool_changed.emit(tool)

    def _reset_picks(self) -> None:
        self.state = PickState()
        self.digitising = _Digitising(self.digitising.kind)
        self.picks_changed.emit()

    def _snapshot(self) -> tuple:
        return self.state, self.digitising.vertices, self.last_point

    def _restore(self, snapshot: tuple) -> None:
        self.state, vertices, self.last_point = snapshot
        self.digitising = _Digitising(self.digitising.kind, vertices)
        self.picks_changed.emit()

    def _change(self, label: str, apply: Callable[[], None]) -> None:
        """Run a change of the pick state as one undoable command."""
        before = self._snapshot()
        apply()
        after = self._snapshot()
        self.undo.push(Command(label, lambda: self._restore(after), lambda: self._restore(before)))

    # ------------------------------------------------------------------ picking
    def _check_pixel(self, side: str, pixel) -> tuple[float, float]:
        if not self.images:
            raise UsvipsError("no image pair is shown")
        x, y = (float(v) for v in pixel)
        h, w = self.images[side].shape[:2]
        if not (np.isfinite(x) and np.isfinite(y) and -0.5 <= x <= w - 0.5 and -0.5 <= y <= h - 0.5):
            raise UsvipsError(f"({x:.1f}, {y:.1f}) is outside the {side} image ({w} × {h} px)")
        return x, y

    def _snapped(self, side: str, pixel: tuple[float, float]) -> tuple[tuple[float, float], str]:
        if not self.snap:
            return pixel, ""
        for window in (41, 81):  # large targets (near the camera, big images) need the wider window
            found = locate_disc(self.images[side], pixel, window=window)
            if found or "window edge" not in found.reason:
                break
        if found:
            return (float(found.center[0]), float(found.center[1])), f"snapped to a target centre ({side})"
        return pixel, f"not snapped ({side}): {found.reason}; your click is kept"

    def pick(self, side: str, pixel) -> None:
        """A click in one image. First pick of a vertex: draw the epipolar curve in the other image and
        propose the conjugate. A click in the other image corrects the proposal and completes the vertex."""
        pixel = self._check_pixel(side, pixel)
        pixel, note = self._snapped(side, pixel)
        state = self.state
        if state.source is not None and state.source != side:
            self._complete_vertex(replace(state, **{side: pixel}), note)
            return
        new = self._first_pick(side, pixel, note)
        self._change(f"pick ({side})", lambda: self._set_state(new))

    def _set_state(self, state: PickState) -> None:
        self.state = state

    def _first_pick(self, side: str, pixel: tuple[float, float], note: str, match: bool = True) -> PickState:
        if self.geometry is None:
            return PickState(**{side: pixel}, source=side, note=note or "no calibration: no epipolar curve")
        rig = self.geometry.calibration.rig(self.geometry.station, self.geometry.frame)
        cameras = {"left": rig.left, "right": rig.right}
        curve = epipolar_curve(cameras[side], cameras[other(side)], pixel, self.near_m, self.far_m, samples=400)
        notes = [note] if note else []
        proposal, weak = None, False
        if len(curve.pixels) == 0:
            notes.append(f"the epipolar curve of this point does not enter the {other(side)} image")
        elif self.auto_match and match:
            try:
                match = match_along_curve(self.images[side], self.images[other(side)], pixel, curve)
            except UsvipsError as error:
                match, reason = None, str(error)
            else:
                reason = match.reason
            if match is not None and match.proposal is not None:
                # a confident match, or the best candidate on the curve when auto-match refused it (weak:
                # its score and why are said, and Enter accepts it all the same, a click corrects it)
                proposal, snap_note = self._snapped(other(side), match.proposal)
                weak = not match
                notes.append(f"{match.describe()}; Enter accepts, a click corrects"
                             + (f"; {snap_note}" if snap_note else ""))
            else:
                notes.append(f"no automatic match: {reason}; click the point in the {other(side)} image")
        return PickState(**{side: pixel}, source=side, curve=curve.pixels, proposal=proposal, note="; ".join(notes),
                         weak=weak)

    def accept_proposal(self) -> None:
        """Take the auto-match proposal as the second pick and complete the vertex; with a vertex held by
        a guard rail, keep it as it is (flagged)."""
        state = self.state
        if state.pending is not None:
            self._take_vertex(replace(state.pending, flags=self.vertex_warnings(state, state.pending)), "")
            return
        if state.proposal is None:
            raise UsvipsError("there is no proposed match to accept: click the point in the other image")
        self._complete_vertex(replace(state, **{other(state.source): state.proposal}), "")

    def nudge(self, dx: float, dy: float) -> str:
        """Move the current pick by (``dx``, ``dy``) image pixels (x right, y down), as one undoable step:
        the proposed match when there is one (it is what Enter accepts), otherwise the first pick (its
        epipolar curve is redrawn; no new proposal is made, so the next nudge moves the same pick).
        Returns a line saying what moved and where."""
        state = self.state
        if state.source is None:
            raise UsvipsError("nothing to nudge: click a point first (Ctrl+arrows move it 0.1 px, "
                              "Ctrl+Shift+arrows 1 px)")
        if state.proposal is not None:
            side = other(state.source)
            x, y = self._check_pixel(side, (state.proposal[0] + dx, state.proposal[1] + dy))
            text = f"proposed match ({side}) moved to ({x:.2f}, {y:.2f}); Enter accepts"
            new = replace(state, proposal=(x, y), note=text)
        else:
            side = state.source
            pick = state.pick(side)
            x, y = self._check_pixel(side, (pick[0] + dx, pick[1] + dy))
            text = f"pick ({side}) moved to ({x:.2f}, {y:.2f})"
            new = self._first_pick(side, (x, y), text, match=False)
        self._change(f"nudge ({side})", lambda: self._set_state(new))
        return text

    def cancel_vertex(self) -> None:
        if self.state.source is None and self.repick is not None:
            self.repick = None
            self.message.emit("info", "re-picking cancelled: the vertex stays where it was")
            self.picks_changed.emit()
            return
        if self.state.source is not None:
            self._change("cancel pick", lambda: self._set_state(PickState()))

    def _complete_vertex(self, state: PickState, note: str) -> None:
        """Intersect a vertex's two picks; a failed intersection leaves the first pick standing."""
        if self.digitising.kind == OBSERVE:
            self._change("observation", lambda: self._set_state(PickState(note=note)))
            self.observed.emit(state.left, state.right)
            return
        try:
            vertex = self.intersect(state.left, state.right)
        except UsvipsError as error:
            self.message.emit("error", f"{error}; pick the point again")
            return
        warnings = self.vertex_warnings(state, vertex)
        if warnings and (self.digitising.kind != "pick" or self.repick is not None):
            text = (f"held, not stored — Enter keeps it (flagged), a click in the {other(state.source)} image "
                    f"corrects it, Esc drops it: {'; '.join(warnings)}")
            held = replace(state, pending=vertex, proposal=None, weak=False, note=text)
            self.message.emit("warning", text)
            self._change("held vertex", lambda: self._set_state(held))
            return
        self._take_vertex(replace(vertex, flags=warnings), note)  # the pick tool only shows its warnings

    def vertex_warnings(self, state: PickState, vertex: MeasuredVertex) -> tuple[str, ...]:
        """The guard rails a vertex breaks: its second pick off the epipolar curve of the first by more
        than :attr:`max_off_curve_px`, and the quality rules on ray RMS and range."""
        warnings = []
        second = state.pick(other(state.source)) if state.source is not None else None
        if second is not None and state.curve is not None and len(state.curve) > 1:
            off = EpipolarCurve(state.curve, np.zeros(len(state.curve))).distance_to(np.array(second))
            if off > self.max_off_curve_px:
                warnings.append(f"the {other(state.source)} pick is {off:.1f} px off the epipolar curve "
                                f"(> {self.max_off_curve_px:g} px)")
        warnings.extend(vertex_failures(self.rules, vertex.ray_rms_m, vertex.range_m))
        return tuple(warnings)

    def _take_vertex(self, vertex: MeasuredVertex, note: str) -> None:
        """Add an intersected vertex to the object being digitised (a point object is stored at once), or
        put it in place of the stored vertex being re-picked."""
        if self.repick is not None:
            self._replace_vertex(vertex)
            return
        kind = self.digitising.kind
        self.message.emit("warning" if vertex.flags else "info", describe_point(vertex)
                          + (f" — kept, flagged: {'; '.join(vertex.flags)}" if vertex.flags else ""))
        if kind not in ("pick", LINE) and measurement_kind(kind).maximum_vertices == len(self.digitising.vertices) + 1:
            self.finish_object(self.attribute, vertices=(vertex,))  # a point (or any kind whose last vertex is in)
            return

        def add() -> None:
            self.state = PickState(note=note)
            self.last_point = vertex
            if kind != "pick":
                self.digitising = _Digitising(kind, self.digitising.vertices + (vertex,))

        self._change("vertex", add)

    def conjugate(self, side: str, pixel, depth_m: float | None = None) -> tuple[float, float] | None:
        """Where ``pixel`` (x, y) of the ``side`` image appears in the other image for a point ``depth_m``
        metres along its ray in the water: by default as far along it as the last measured point (the
        current working depth), else :data:`LINK_DEPTH_M`. None without a calibration, or when the point
        falls outside the other camera's view. Linked navigation follows this, not the same pixel."""
        if self.geometry is None:
            return None
        rig = self.geometry.calibration.rig(self.geometry.station, self.geometry.frame)
        cameras = {"left": rig.left, "right": rig.right}
        bundle = cameras[side].rays(np.array([pixel], dtype=np.float64))
        if not bundle.ok[0]:
            return None
        origin, direction = bundle.origins[0], bundle.directions[0]
        if depth_m is None:
            depth_m = (float(np.linalg.norm(self.last_point.xyz - origin)) if self.last_point is not None
                       else LINK_DEPTH_M)
        projection = cameras[other(side)].project((origin + depth_m * direction)[None, :])
        return (float(projection.pixels[0, 0]), float(projection.pixels[0, 1])) if projection.ok[0] else None

    def intersect(self, left, right) -> MeasuredVertex:
        """Intersect one pair of picks with the pair's calibration (pointing and calibration covariance)."""
        if self.geometry is None:
            raise UsvipsError(f"pair {self.pair!r} has no active calibration: nothing can be intersected")
        g = self.geometry
        try:  # the one intersection with ray RMS and range (usvips.core.measurements.intersect_vertices)
            points, covariance, ray_rms_m, range_m = intersect_vertices(g.calibration, np.array([left], float),
                                                                        np.array([right], float), g.station, g.frame)
        except DegenerateGeometryError as error:
            raise UsvipsError(f"the rays do not intersect: {str(error).removeprefix('vertex 0: ')}") from None
        return MeasuredVertex(tuple(left), tuple(right), points[0], covariance, ray_rms_m, range_m)

    # ------------------------------------------------------------------ objects
    def finish_object(self, attribute: str = "", notes: str = "",
                      vertices: tuple[MeasuredVertex, ...] | None = None) -> int:
        """Store the object being digitised (one transaction; undoable) and start the next one.
        ``vertices``: store these instead (a point object is stored as its vertex completes)."""
        last = vertices[-1] if vertices else None
        vertices = self.digitising.vertices if vertices is None else self.digitising.vertices + vertices
        if self.digitising.kind == "pick":
            raise UsvipsError("the pick tool measures single points without storing them: choose "
                              f"{', '.join(TOOLS[1:])} to measure an object")
        kind = resolve(self.digitising.kind, len(vertices))
        measurement_kind(kind).check_count(len(vertices))
        if self.project is None:
            raise UsvipsError("open a project first")
        flags = [f"vertex {i + 1}: {flag}" for i, v in enumerate(vertices) for flag in v.flags]
        if flags:
            notes = "; ".join(filter(None, [notes, "flagged: " + "; ".join(flags)]))
        stored = self._vertices_for_store(vertices)
        holder: dict = {"id": None, "rows": None}
        before = self._snapshot()

        def store() -> None:
            first = holder["rows"] is None
            if first:
                holder["id"] = self.project.add_object(kind, stored, attribute, notes)
                if attribute:
                    self.project.add_term(attribute)
            else:  # redo: the very object (id, record, times) that undo took away
                self.project.put_back(holder["rows"])
            self.digitising = _Digitising(self.digitising.kind)
            self.state = PickState()
            if last is not None:
                self.last_point = last
            self._objects_changed_in_store(added=(holder["id"],))
            self.picks_changed.emit()
            if first:
                self.stored.emit(holder["id"])

        def unstore() -> None:
            holder["rows"] = self.project.take_object(holder["id"])
            self._restore(before)
            self._objects_changed_in_store(removed=(holder["id"],))

        self.undo.push(Command(f"store {kind}", store, unstore))
        result = self.figures([holder["id"]])
        main = result.figures[0] if result.figures and kind != "point" else None
        self.message.emit("warning" if result.failures else "info",
                          f"stored {kind} {holder['id']}" + (f": {format_figure(main)}" if main else "")
                          + (f" — quality: {'; '.join(result.failures)}" if result.failures else ""))
        return holder["id"]

    def _vertices_for_store(self, vertices: tuple[MeasuredVertex, ...]) -> list[Vertex]:
        g = self.geometry
        return [Vertex(*v.left, *v.right, tuple(float(c) for c in v.xyz), v.covariance,
                       g.calibration_id if g else None, self.pair, *(self.video_frame or ())) for v in vertices]

    def start_repick(self, object_id: int, index: int) -> None:
        """Re-pick vertex ``index`` (0-based) of a stored object: the next vertex measured (both picks, the
        guard rails as usual) replaces it, as one undoable step; Esc before the first pick cancels."""
        if self.project is None:
            raise UsvipsError("open a project first")
        stored = self.stored_object(object_id)
        if not 0 <= index < len(stored.vertices):
            raise UsvipsError(f"{stored.kind} {object_id} has vertices 1 to {len(stored.vertices)}, not {index + 1}")
        pair = stored.vertices[index].pair
        if pair != self.pair:
            raise UsvipsError(f"vertex {index + 1} of {stored.kind} {object_id} was measured on pair {pair!r}: "
                              "show that pair first")
        if self.digitising.vertices:
            raise UsvipsError(f"finish or cancel the {self.digitising.kind} being digitised first")
        self.repick = (object_id, index)
        self.state = PickState(note=f"re-pick vertex {index + 1} of {stored.kind} {object_id}: click it in "
                                    "either image (Esc cancels)")
        self.picks_changed.emit()

    def _replace_vertex(self, vertex: MeasuredVertex) -> None:
        object_id, index = self.repick
        self.repick = None
        saved = list(self.stored_object(object_id).vertices)
        new = list(saved)
        new[index] = self._vertices_for_store((vertex,))[0]
        self._set_vertices(f"re-pick vertex {index + 1} of object {object_id}", object_id, saved, new)
        self.last_point = vertex

    def delete_vertex(self, object_id: int, index: int) -> None:
        """Remove vertex ``index`` (0-based) of a stored object (undoable); an object keeps at least the
        vertices its kind needs (delete the object instead)."""
        stored = self.stored_object(object_id)
        if not 0 <= index < len(stored.vertices):
            raise UsvipsError(f"{stored.kind} {object_id} has vertices 1 to {len(stored.vertices)}, not {index + 1}")
        least = measurement_kind(resolve(stored.kind, len(stored.vertices))).minimum_vertices
        if len(stored.vertices) - 1 < least:
            raise UsvipsError(f"{article(stored.kind)} needs at least {plural(least, 'vertex')}: delete the object "
                              "instead")
        saved = list(stored.vertices)
        self._set_vertices(f"delete vertex {index + 1} of object {object_id}", object_id, saved,
                           saved[:index] + saved[index + 1:])

    def _set_vertices(self, label: str, object_id: int, before: list[Vertex], after: list[Vertex]) -> None:
        def picks_reset() -> None:
            self.state = PickState()
            self.picks_changed.emit()

        self._edit_object(label, object_id, lambda: self.project.update_object(object_id, vertices=after),
                          picks_reset)
        self.message.emit("info", f"{label}: done (Ctrl+Z undoes it)")

    def _edit_object(self, label: str, object_id: int, edit: Callable[[], None],
                     then: Callable[[], None] | None = None) -> None:
        """Run ``edit`` of a stored object as one undoable command. Undo puts back the object's stored rows
        as they were before (vertices, kind, texts, record, history: exactly, nothing added); redo puts
        back the rows the edit made."""
        before = self.project.object_rows(object_id)
        after: list = []

        def put(rows) -> None:
            self.project.put_back(rows, replace=True)

        def redo() -> None:
            if after:
                put(after[0])
            else:
                edit()
                after.append(self.project.object_rows(object_id))
            self._objects_changed_in_store(updated=(object_id,))
            if then is not None:
                then()

        def undo() -> None:
            put(before)
            self._objects_changed_in_store(updated=(object_id,))
            if then is not None:
                then()

        self.undo.push(Command(label, redo, undo))

    def delete_object(self, object_id: int) -> None:
        """Delete a stored object (undoable: undo gives back the same id with its vertices, video frames,
        observation record and history)."""
        saved = self.stored_object(object_id)
        removed: list = []

        def delete() -> None:
            removed[:] = [self.project.take_object(object_id)]
            self._objects_changed_in_store(removed=(object_id,))

        def restore() -> None:
            self.project.put_back(removed[0])
            self._objects_changed_in_store(added=(object_id,))

        self.undo.push(Command(f"delete {saved.kind} {object_id}", delete, restore))

    def kinds_for(self, object_id: int) -> list[str]:
        """The registered measurement kinds a stored object's vertices can make (its own first)."""
        stored = self.stored_object(object_id)
        count = len(stored.vertices)
        fitting = [k.name for k in registered_kinds() if k.minimum_vertices <= count
                   and (k.maximum_vertices is None or count <= k.maximum_vertices)]
        return sorted(fitting, key=lambda name: name != stored.kind)

    def change_kind(self, object_id: int, kind: str) -> None:
        """Make a stored object another measurement kind (an arc a polygon, say), keeping its vertices;
        undoable. Refused by name when the vertices cannot make that kind."""
        stored = self.stored_object(object_id)
        if kind == stored.kind:
            return
        if kind not in self.kinds_for(object_id):
            raise UsvipsError(f"{stored.kind} {object_id} has {plural(len(stored.vertices), 'vertex')}: it cannot be "
                              f"{article(kind)} (it can be {', '.join(self.kinds_for(object_id))})")

        self._edit_object(f"make object {object_id} {article(kind)}", object_id,
                          lambda: self.project.update_object(object_id, kind=kind))
        self.message.emit("info", f"object {object_id} is now {article(kind)} (Ctrl+Z undoes it)")

    def edit_object(self, object_id: int, attribute: str, notes: str) -> None:
        self.stored_object(object_id)

        def edit() -> None:
            self.project.update_object(object_id, attribute=attribute, notes=notes)
            if attribute:
                self.project.add_term(attribute)

        self._edit_object(f"edit object {object_id}", object_id, edit)

    def frame_description(self, object_id: int) -> str:
        """The frame an object's coordinates (and so its bearing and slope) are given in, in words."""
        stored = self.stored_object(object_id)
        g = measurement_input(self.project, stored, self._calibrations)
        if g.calibration is None:
            return "the frame it was measured in (its calibration is no longer in the project)"
        if g.frame == "object":
            return f"the object frame of station {g.station} (the control points' axes)"
        return "the rig frame (origin at the left camera; X right, Y up, the camera looking along −Z)"

    def set_record(self, object_id: int, record: ObservationRecord | None) -> None:
        """Store an object's observation record (species, number, stage, activity, comment); undoable."""
        self._edit_object(f"observation record of object {object_id}", object_id,
                          lambda: self.project.set_record(object_id, record))

    # ------------------------------------------------------------------ the stored objects (cached)
    # held by ``self.cache`` (usvips.gui.object_cache.ObjectCache), a new one per project; these delegate
    def objects(self) -> list:
        """The project's stored objects in id order, from the model's cache (no query)."""
        return self.cache.objects()

    def object_ids(self) -> list[int]:
        return self.cache.ids()

    def stored_object(self, object_id: int):
        """One stored object from the cache (raises by name when there is none)."""
        return self.cache.get(object_id)

    def object_record(self, object_id: int) -> ObservationRecord | None:
        """A stored object's observation record (its species, number ...), from the cache."""
        return self.cache.record(object_id)

    @property
    def _calibrations(self) -> dict[int, StereoCalibration | None]:
        return self.cache.calibrations

    def _objects_changed_in_store(self, added: tuple[int, ...] = (), updated: tuple[int, ...] = (),
                                  removed: tuple[int, ...] = ()) -> None:
        """The cache brought up to date with what was just written (announced by id); the selection
        drops the objects gone."""
        gone = self.cache.changed_in_store(added, updated, removed)
        if set(gone) & set(self.selection):
            self.select([i for i in self.selection if i not in gone])

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

    def set_rules(self, rules: QualityRules) -> None:
        """New quality rules: every object's verdict may change (its figures are computed again)."""
        if rules == self.rules:
            return
        self.rules = rules
        self.cache.forget_figures()
        self.rules_changed.emit(rules)

    def object_figures(self, object_id: int) -> Result | None:
        """An object's figures when they are known under the current rules (None: not yet computed)."""
        return self.cache.known_figures(object_id)

    def forget_figures(self) -> None:
        """Drop every computed figure (they are computed again when asked for)."""
        self.cache.forget_figures()

    # ------------------------------------------------------------------ geo-calculator
    def figures_job(self, object_ids: list[int]) -> Callable[..., dict[int, Result]]:
        """The figures of many objects as a function of copied inputs (run it off the GUI thread); give its
        result to :meth:`remember_figures`."""
        return self.cache.figures_job(object_ids)

    def remember_figures(self, job: Callable[..., dict[int, Result]], results: dict[int, Result]) -> list[int]:
        """Keep what :meth:`figures_job`'s ``job`` computed, except for objects changed (or rules changed)
        since it was made; returns the ids kept."""
        return self.cache.remember(job, results)

    def figures(self, object_ids: list[int]) -> Result:
        """The geo-calculator on a selection of one or two objects (one object's figures are computed once
        per change and kept)."""
        return self.cache.figures(object_ids)

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

    # ---- survey (issue 25): a minimal propose_vertex until station's lands; the lead reconciles ----
    def propose_vertex(self, left, right, note: str = "") -> None:
        """Put a proposed vertex in the pick state (a track-based proposal): ``left`` (px) as the first
        pick, its epipolar curve drawn in the right image, and ``right`` (px) as the proposed match that
        Enter accepts and a click corrects; one undoable step."""
        left = self._check_pixel("left", left)
        right = self._check_pixel("right", right)
        state = self._first_pick("left", left, "", match=False)
        new = replace(state, proposal=right, weak=False,
                      note="; ".join(t for t in (note, "Enter accepts, a click in the right image corrects") if t))
        self._change("proposed vertex", lambda: self._set_state(new))
    # ---- end survey ----


def describe_point(vertex: MeasuredVertex) -> str:
    """``X Y Z (m) ± sX sY sZ (mm)``, ray RMS and range: the status-bar readout of an intersection."""
    x, y, z = vertex.xyz
    sx, sy, sz = vertex.sigmas * 1000
    return (f"X {x:.4f}  Y {y:.4f}  Z {z:.4f} m   ± {sx:.1f} / {sy:.1f} / {sz:.1f} mm   "
            f"ray RMS {vertex.ray_rms_m * 1000:.1f} mm, range {vertex.range_m:.2f} m")
