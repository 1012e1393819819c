"""The picking and measuring tool, free of Qt: the digitising state machine of the workstation.

A vertex is digitised by a first pick in one image (its epipolar curve is drawn in the other, auto-match
proposes the conjugate there), then a click in the other image, or Enter on the proposal; the two picks
are intersected with the pair's calibration, checked by the guard rails (off the curve, ray RMS, range:
a vertex that breaks one is HELD until the user keeps it, flagged, or corrects it) and added to the object
being digitised; finishing stores it. Every step is a :class:`~usvips.gui.undo.Command` on the scene's
one undo stack that restores exactly what it changed (the pick state, the vertices, the last point; a
stored object's very rows: id, record, history).

The tool measures on a :class:`PickScene` — the pair shown, its images and calibration, the open
project — which the workspace (:mod:`usvips.gui.workspace`) is; the workspace makes a NEW tool for every
project (nothing of the previous one survives) and hands it the same :class:`PickEvents`, so views
connect once.

Pixels follow ARCHITECTURE.md: x right, y down, origin at the centre of the top-left pixel (float64).
3-D points are metres in the frame of the pair's calibration (the object frame when the pair is a
calibrated station, otherwise the rig frame, origin at the left camera's perspective centre).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from usvips.app.pair_geometry import PairGeometry
from usvips.app.quality import object_facts
from usvips.core.errors import DegenerateGeometryError, UsvipsError
from usvips.core.matching import EpipolarCurve, epipolar_curve, match_along_curve
from usvips.core.measurements import QualityRules, intersect_vertices, names, resolve
from usvips.core.measurements import kind as measurement_kind
from usvips.core.measurements.breakdown import breakdown_text
from usvips.core.pointing import WeakMatch
from usvips.core.targets import locate_disc
from usvips.gui.calculator import Result, format_figure, vertex_failures
from usvips.gui.signals import Signal
from usvips.gui.undo import Command, UndoStack
from usvips.gui.wording import plural
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
    ``source`` (the side picked first), the ``proposal`` there (auto-match's, or one put by
    :meth:`PickTool.propose_vertex`; ``weak`` when auto-match refused it but it is the best candidate on
    the curve: drawn apart, accepted by Enter all the same, and the vertex kept from it is flagged with
    ``weak_reason``), and a note for the user."""

    left: tuple[float, float] | None = None
    right: tuple[float, float] | None = None
    source: str | None = None
    curve: np.ndarray | None = None
    proposal: tuple[float, float] | None = None
    note: str = ""
    weak: bool = False
    #: A vertex intersected from both picks but held back by a guard rail until the user keeps it (Enter).
    pending: MeasuredVertex | None = None
    #: Why a weak proposal is weak, with its score ("score 0.42: the best correlation 0.42 is below 0.50").
    weak_reason: str = ""
    #: What a vertex kept from the weak proposal stores (:class:`usvips.core.pointing.WeakMatch`): the
    #: matcher's score (None for a proposal put from elsewhere) and its reason.
    weak_match: WeakMatch | None = None
    #: Where the proposal's pixels come from (:mod:`usvips.core.pointing`): auto-match's, or a track's when
    #: put by :meth:`PickTool.propose_vertex` — the source a vertex kept from it stores.
    proposal_source: str = "auto-match"

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
    #: Where its pixels come from (:mod:`usvips.core.pointing`: "hand click", or "auto-match" when its second
    #: pick is an accepted proposal) and, kept from a weak proposal, the matcher's flag — stored with the
    #: vertex, as facts, not in the notes.
    source: str = "hand click"
    weak: WeakMatch | None = None

    @property
    def sigmas(self) -> np.ndarray:
        return np.sqrt(np.clip(np.diag(self.covariance), 0, None))


@dataclass
class Digitising:
    """The object being digitised: its kind (the tool) and the vertices measured so far."""

    kind: str
    vertices: tuple[MeasuredVertex, ...] = ()


@dataclass
class PickSettings:
    """The user's settings of the tool (kept from project to project): snap a pick to a target centre,
    propose the conjugate by auto-match, the depth range (m) of the epipolar curve, and how far (pixels)
    a second pick may lie off the first pick's curve before the vertex is held for a check."""

    snap: bool = False
    auto_match: bool = True
    near_m: float = 0.2
    far_m: float = 20.0
    max_off_curve_px: float = 5.0


@dataclass
class PickEvents:
    """``picks_changed()`` (the pick state, the object being digitised or the last measured point
    changed), ``tool_changed(tool)``, ``observed(left, right)`` when the observe tool has both picks of a
    point, ``stored(object_id)`` after a newly measured object is stored."""

    picks_changed: Signal = field(default_factory=Signal)
    tool_changed: Signal = field(default_factory=Signal)
    observed: Signal = field(default_factory=Signal)
    stored: Signal = field(default_factory=Signal)


@dataclass
class _StoredPick:
    """An object the pick tool stored, across undo and redo: its ``id`` in the project, the store's
    ``rows`` undo took away (None until undone: redo puts these very rows back) and the ``modified`` time
    it was stored with (undo refuses when another annotator changed it since)."""

    id: int | None = None
    rows: object | None = None
    modified: object | None = None


class PickScene(Protocol):
    """What the tool measures on (the workspace): the open project, the pair shown with its images
    (side -> array) and calibration (None: picks only), the video frame when the pair is a video's frame
    pair, the quality rules, the one undo stack and ``message(level, text)``; and the stored objects."""

    project: ProjectStore | None
    pair: str | None
    images: dict[str, np.ndarray]
    geometry: PairGeometry | None
    video_frame: tuple[str, int, int, float] | None
    rules: QualityRules
    undo: UndoStack
    message: Signal

    def stored_object(self, object_id: int): ...

    def objects_changed_in_store(self, added: tuple[int, ...] = (), updated: tuple[int, ...] = (),
                                 removed: tuple[int, ...] = ()) -> None: ...

    def figures(self, object_ids: list[int]) -> Result: ...

    def edit_stored(self, label: str, object_id: int, edit: Callable[[], None],
                    then: Callable[[], None] | None = None) -> None: ...


def describe_point(vertex: MeasuredVertex) -> str:
    """``X Y Z (m) ± sX sY sZ (mm)``, ray RMS and range: the status-bar readout of an intersection."""
    x, y, z = vertex.xyz
    sx, sy, sz = vertex.sigmas * 1000
    return (f"X {x:.4f}  Y {y:.4f}  Z {z:.4f} m   ± {sx:.1f} / {sy:.1f} / {sz:.1f} mm   "
            f"ray RMS {vertex.ray_rms_m * 1000:.1f} mm, range {vertex.range_m:.2f} m")


class PickTool:
    """The digitising state machine on ``scene``: :attr:`state` (the vertex being picked),
    :attr:`digitising` (the object being digitised), :attr:`last_point`, :attr:`repick` and the
    :attr:`attribute` of the next stored object. Announces through ``events``."""

    def __init__(self, scene: PickScene, events: PickEvents, settings: PickSettings, tool: str = "pick") -> None:
        self.scene = scene
        self.events = events
        self.settings = settings
        self.state = PickState()
        self.digitising = Digitising(tool)
        self.last_point: MeasuredVertex | None = None
        #: The attribute given to the next stored object (the window's Attribute box keeps it current).
        self.attribute = ""
        #: (object id, vertex index from 0) that the next measured vertex replaces, or None.
        self.repick: tuple[int, int] | None = None

    # ------------------------------------------------------------------ tool
    @property
    def tool(self) -> str:
        return self.digitising.kind

    def set_tool(self, tool: str) -> None:
        if tool not in TOOLS + (OBSERVE,):
            raise UsvipsError(f"unknown tool {tool!r}; tools: {', '.join(TOOLS)}")
        if self.digitising.vertices:
            self.scene.message.emit("warning", f"the unfinished {self.digitising.kind} "
                                               f"({plural(len(self.digitising.vertices), 'vertex')}) was dropped")
        self.digitising = Digitising(tool)
        self.reset()
        self.events.tool_changed.emit(tool)

    def reset(self) -> None:
        """No vertex being picked, no object being digitised (the tool and the last point stay)."""
        self.state = PickState()
        self.digitising = Digitising(self.digitising.kind)
        self.events.picks_changed.emit()

    def clear_state(self) -> None:
        """No vertex being picked (the object being digitised stays)."""
        self.state = PickState()
        self.events.picks_changed.emit()

    def _snapshot(self) -> tuple:
        return self.state, self.digitising.vertices, self.last_point

    def _restore(self, snapshot: tuple) -> None:
        self.state, vertices, self.last_point = snapshot
        self.digitising = Digitising(self.digitising.kind, vertices)
        self.events.picks_changed.emit()

    def _change(self, label: str, apply: Callable[[], None]) -> None:
        """Run a change of the pick state as one undoable command (undo restores the state, the vertices
        and the last point exactly as they were)."""
        before = self._snapshot()
        apply()
        after = self._snapshot()
        self.scene.undo.push(Command(label, lambda: self._restore(after), lambda: self._restore(before),
                                     pair_bound=True))

    def _where(self) -> tuple:
        """Where picks are made now: the pair shown and, on a video, its frame pair."""
        return self.scene.pair, self.scene.video_frame

    def _set_state(self, state: PickState) -> None:
        self.state = state

    # ------------------------------------------------------------------ picking
    def _check_pixel(self, side: str, pixel) -> tuple[float, float]:
        images = self.scene.images
        if not images:
            raise UsvipsError("no image pair is shown")
        try:
            x, y = (float(v) for v in pixel)
        except (TypeError, ValueError):
            raise UsvipsError(f"a {side} pixel is two numbers (x, y), got {pixel!r}") from None
        h, w = images[side].shape[:2]
        if not (np.isfinite(x) and np.isfinite(y) and -0.5 <= x <= w - 0.5 and -0.5 <= y <= h - 0.5):
            raise UsvipsError(f"({x:.1f}, {y:.1f}) is outside the {side} image ({w} × {h} px)")
        return x, y

    def _snapped(self, side: str, pixel: tuple[float, float]) -> tuple[tuple[float, float], str]:
        if not self.settings.snap:
            return pixel, ""
        for window in (41, 81):  # large targets (near the camera, big images) need the wider window
            found = locate_disc(self.scene.images[side], pixel, window=window)
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

    def _curve(self, side: str, pixel: tuple[float, float]) -> EpipolarCurve | None:
        """The epipolar curve in the other image of ``pixel`` of ``side`` (its pixels and depths along
        the ray, m); None without a calibration."""
        g = self.scene.geometry
        if g is None:
            return None
        rig = g.calibration.rig(g.station, g.frame)
        cameras = {"left": rig.left, "right": rig.right}
        return epipolar_curve(cameras[side], cameras[other(side)], pixel, self.settings.near_m,
                              self.settings.far_m, samples=400)

    def _first_pick(self, side: str, pixel: tuple[float, float], note: str, match: bool = True) -> PickState:
        curve = self._curve(side, pixel)
        if curve is None:
            return PickState(**{side: pixel}, source=side, note=note or "no calibration: no epipolar curve")
        notes = [note] if note else []
        proposal, weak, weak_reason, weak_match = None, False, "", None
        if len(curve.pixels) == 0:
            notes.append(f"the epipolar curve of this point does not enter the {other(side)} image")
        elif self.settings.auto_match and match:
            images = self.scene.images
            try:
                found = match_along_curve(images[side], images[other(side)], pixel, curve)
            except UsvipsError as error:
                found, reason = None, str(error)
            else:
                reason = found.reason
            if found is not None and found.proposal is not None:
                # a confident match, or the best candidate on the curve when auto-match refused it (weak:
                # its score and why are said, and Enter accepts it all the same, a click corrects it)
                proposal, snap_note = self._snapped(other(side), found.proposal)
                weak = not found
                weak_reason = f"score {found.score:.2f}: {found.reason}" if weak else ""
                weak_match = WeakMatch(float(found.score), found.reason) if weak else None
                notes.append(f"{found.describe()}; Enter accepts, a click corrects"
                             + (f"; {snap_note}" if snap_note else ""))
            else:
                notes.append(f"no automatic match: {reason}; click the point in the {other(side)} image")
        return PickState(**{side: pixel}, source=side, curve=curve.pixels, proposal=proposal, note="; ".join(notes),
                         weak=weak, weak_reason=weak_reason, weak_match=weak_match)

    def propose_vertex(self, left, right, note: str, weak: bool = False) -> None:
        """Propose a whole vertex, as auto-match proposes one (for proposals made elsewhere, e.g. from a
        track): ``left`` (x, y) px becomes the first pick (its epipolar curve is drawn in the right image),
        ``right`` (x, y) px the proposal shown there; Enter keeps it (the guard rails as usual), a click in
        the right image corrects it, Esc drops it. ``note`` is shown to the user; ``weak``: the proposal
        is uncertain (drawn apart; a vertex kept from it is flagged with ``note``). One undoable step."""
        left = self._check_pixel("left", left)
        right = self._check_pixel("right", right)
        curve = self._curve("left", left)
        text = f"{note}; Enter accepts, a click corrects" if note else "proposed match: Enter accepts, a click corrects"
        new = PickState(left=left, source="left", curve=None if curve is None else curve.pixels, proposal=right,
                        note=text, weak=bool(weak), weak_reason=note if weak else "",
                        weak_match=WeakMatch(None, note or "a proposal marked uncertain") if weak else None,
                        proposal_source="tracked")
        self._change("proposed vertex", lambda: self._set_state(new))

    def accept_proposal(self) -> None:
        """Take the proposal as the second pick and complete the vertex (one kept from a weak proposal is
        flagged so); with a vertex held by a guard rail, keep it as it is (flagged)."""
        state = self.state
        if state.pending is not None:
            self._take_vertex(replace(state.pending, flags=state.pending.flags + self.vertex_warnings(
                state, state.pending)), "")
            return
        if state.proposal is None:
            raise UsvipsError("there is no proposed match to accept: click the point in the other image")
        self._complete_vertex(replace(state, **{other(state.source): state.proposal}), "",
                              source=state.proposal_source, weak=state.weak_match if state.weak else None)

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
        """Esc: drop the vertex being picked (undoable); before any pick, stop re-picking."""
        if self.state.source is None and self.repick is not None:
            self.repick = None
            self.scene.message.emit("info", "re-picking cancelled: the vertex stays where it was")
            self.events.picks_changed.emit()
            return
        if self.state.source is not None:
            self._change("cancel pick", lambda: self._set_state(PickState()))

    def _complete_vertex(self, state: PickState, note: str, source: str = "hand click",
                         weak: WeakMatch | None = None) -> None:
        """Intersect a vertex's two picks; a failed intersection leaves the first pick standing. ``source``:
        where its pixels come from; ``weak``: the flag of a weak proposal accepted, which the vertex carries
        whatever the guard rails say."""
        if self.digitising.kind == OBSERVE:
            self._change("observation", lambda: self._set_state(PickState(note=note)))
            self.events.observed.emit(state.left, state.right)
            return
        try:
            vertex = replace(self.intersect(state.left, state.right), source=source, weak=weak)
        except UsvipsError as error:
            self.scene.message.emit("error", f"{error}; pick the point again")
            return
        warnings = self.vertex_warnings(state, vertex)
        if warnings and (self.digitising.kind != "pick" or self.repick is not None):
            text = (f"held, not stored — Enter keeps it (flagged), a click in the {other(state.source)} image "
                    f"corrects it, Esc drops it: {'; '.join(warnings)}")
            held = replace(state, pending=vertex, proposal=None, weak=False, weak_reason="", weak_match=None, note=text)
            self.scene.message.emit("warning", text)
            self._change("held vertex", lambda: self._set_state(held))
            return
        self._take_vertex(replace(vertex, flags=warnings), note)  # the pick tool only shows warnings

    def vertex_warnings(self, state: PickState, vertex: MeasuredVertex) -> tuple[str, ...]:
        """The guard rails a vertex breaks: its second pick off the epipolar curve of the first by more
        than ``max_off_curve_px``, and the quality rules on ray RMS and range."""
        warnings = []
        second = state.pick(other(state.source)) if state.source is not None else None
        if second is not None and state.curve is not None and len(state.curve) > 1:
            off = EpipolarCurve(state.curve, np.zeros(len(state.curve))).distance_to(np.array(second))
            if off > self.settings.max_off_curve_px:
                warnings.append(f"the {other(state.source)} pick is {off:.1f} px off the epipolar curve "
                                f"(> {self.settings.max_off_curve_px:g} px)")
        warnings.extend(vertex_failures(self.scene.rules, vertex.ray_rms_m, vertex.range_m))
        return tuple(warnings)

    def _take_vertex(self, vertex: MeasuredVertex, note: str) -> None:
        """Add an intersected vertex to the object being digitised (a point object is stored at once), or
        put it in place of the stored vertex being re-picked."""
        if self.repick is not None:
            self._replace_vertex(vertex)
            return
        kind = self.digitising.kind
        said = vertex.flags + ((vertex.weak.text,) if vertex.weak is not None else ())
        self.scene.message.emit("warning" if said else "info", describe_point(vertex)
                                + (f" — kept, flagged: {'; '.join(said)}" if said else ""))
        if kind not in ("pick", LINE) and measurement_kind(kind).maximum_vertices == len(self.digitising.vertices) + 1:
            self.finish_object(self.attribute, vertices=(vertex,))  # a point (or any kind whose last vertex is in)
            return

        def add() -> None:
            self.state = PickState(note=note)
            self.last_point = vertex
            if kind != "pick":
                self.digitising = Digitising(kind, self.digitising.vertices + (vertex,))

        self._change("vertex", add)

    # ------------------------------------------------------------------ geometry
    def conjugate(self, side: str, pixel, depth_m: float | None = None) -> tuple[float, float] | None:
        """Where ``pixel`` (x, y) of the ``side`` image appears in the other image for a point ``depth_m``
        metres along its ray in the water: by default as far along it as the last measured point (the
        current working depth), else :data:`LINK_DEPTH_M`. None without a calibration, or when the point
        falls outside the other camera's view. Linked navigation follows this, not the same pixel."""
        g = self.scene.geometry
        if g is None:
            return None
        rig = g.calibration.rig(g.station, g.frame)
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
        g = self.scene.geometry
        if g is None:
            raise UsvipsError(f"pair {self.scene.pair!r} has no active calibration: nothing can be intersected")
        try:  # the one intersection with ray RMS and range (usvips.core.measurements.intersect_vertices)
            points, covariance, ray_rms_m, range_m = intersect_vertices(g.calibration, np.array([left], float),
                                                                        np.array([right], float), g.station, g.frame)
        except DegenerateGeometryError as error:
            raise UsvipsError(f"the rays do not intersect: {str(error).removeprefix('vertex 0: ')}") from None
        return MeasuredVertex(tuple(left), tuple(right), points[0], covariance, ray_rms_m, range_m)

    # ------------------------------------------------------------------ storing
    def finish_object(self, attribute: str = "", notes: str = "",
                      vertices: tuple[MeasuredVertex, ...] | None = None) -> int:
        """Store the object being digitised (one transaction; undoable: undo takes the very rows away and
        puts the picks back, redo puts back the same id) and start the next one. ``vertices``: store these
        too (a point object is stored as its vertex completes). Flagged vertices are named in the notes."""
        last = vertices[-1] if vertices else None
        vertices = self.digitising.vertices if vertices is None else self.digitising.vertices + vertices
        if self.digitising.kind == "pick":
            raise UsvipsError("the pick tool measures single points without storing them: choose "
                              f"{', '.join(TOOLS[1:])} to measure an object")
        kind = resolve(self.digitising.kind, len(vertices))
        measurement_kind(kind).check_count(len(vertices))
        project = self.scene.project
        if project is None:
            raise UsvipsError("open a project first")
        flags = [f"vertex {i + 1}: {flag}" for i, v in enumerate(vertices) for flag in v.flags]
        if flags:
            notes = "; ".join(filter(None, [notes, "flagged: " + "; ".join(flags)]))
        stored = self._vertices_for_store(vertices)
        holder = _StoredPick()
        before = self._snapshot()
        where = self._where()

        def store() -> None:
            first = holder.rows is None
            if first:
                holder.id = project.add_object(kind, stored, attribute, notes)
                if attribute:
                    project.add_term(attribute)
                holder.modified = project.object(holder.id).modified
            else:  # redo: the very object (id, record, times) that undo took away
                project.put_back(holder.rows)
                holder.modified = holder.rows.modified
            if self._where() == where:  # elsewhere, what is being picked there is not this object's
                self.digitising = Digitising(self.digitising.kind)
                self.state = PickState()
                if last is not None:
                    self.last_point = last
            self.scene.objects_changed_in_store(added=(holder.id,))
            self.events.picks_changed.emit()
            if first:
                self.events.stored.emit(holder.id)

        def unstore() -> None:
            # not when another annotator changed it since (a shared survey): refused by name, it stays
            holder.rows = project.take_object(holder.id, expected_modified=holder.modified)
            if self._where() == where:  # its vertices come back to be finished only where they were picked
                self._restore(before)
            self.scene.objects_changed_in_store(removed=(holder.id,))

        self.scene.undo.push(Command(f"store {kind}", store, unstore))
        result = self.scene.figures([holder.id])
        main = result.figures[0] if result.figures and kind != "point" else None
        measured = result.measurement
        sigma = (" " + breakdown_text(measured).replace("\n", "; ")) if main and measured is not None else ""
        # the one verdict (no record yet: the species rule waits for the observation form's record)
        failures = (object_facts(project.object(holder.id), measured, self.scene.rules) if measured is not None
                    else list(result.failures))
        self.scene.message.emit("warning" if failures else "info",
                                f"stored {kind} {holder.id}" + (f": {format_figure(main)}{sigma}" if main else "")
                                + (f" — quality: {'; '.join(failures)}" if failures else ""))
        return holder.id

    def _vertices_for_store(self, vertices: tuple[MeasuredVertex, ...]) -> list[Vertex]:
        g = self.scene.geometry
        return [Vertex(*v.left, *v.right, tuple(float(c) for c in v.xyz), v.covariance,
                       g.calibration_id if g else None, self.scene.pair, *(self.scene.video_frame or ()),
                       source=v.source, weak=v.weak)
                for v in vertices]

    def start_repick(self, object_id: int, index: int) -> None:
        """Re-pick vertex ``index`` (0-based) of a stored object: the next vertex measured (both picks, the
        guard rails as usual) replaces it, as one undoable step; Esc before the first pick cancels."""
        if self.scene.project is None:
            raise UsvipsError("open a project first")
        stored = self.scene.stored_object(object_id)
        if not 0 <= index < len(stored.vertices):
            raise UsvipsError(f"{stored.kind} {object_id} has vertices 1 to {len(stored.vertices)}, not {index + 1}")
        pair = stored.vertices[index].pair
        if pair != self.scene.pair:
            raise UsvipsError(f"vertex {index + 1} of {stored.kind} {object_id} was measured on pair {pair!r}: "
                              "show that pair first")
        if self.digitising.vertices:
            raise UsvipsError(f"finish or cancel the {self.digitising.kind} being digitised first")
        self.repick = (object_id, index)
        self.state = PickState(note=f"re-pick vertex {index + 1} of {stored.kind} {object_id}: click it in "
                                    "either image (Esc cancels)")
        self.events.picks_changed.emit()

    def _replace_vertex(self, vertex: MeasuredVertex) -> None:
        object_id, index = self.repick
        self.repick = None
        saved = list(self.scene.stored_object(object_id).vertices)
        new = list(saved)
        new[index] = self._vertices_for_store((vertex,))[0]
        label = f"re-pick vertex {index + 1} of object {object_id}"
        project = self.scene.project
        self.scene.edit_stored(label, object_id, lambda version: project.update_object(
            object_id, vertices=new, expected_modified=version), self.clear_state)
        self.scene.message.emit("info", f"{label}: done (Ctrl+Z undoes it)")
        self.last_point = vertex
