"""The 3-D target field service: from the targets a user identified in the two images of a pair, the
rest found through the model, and the confirmed targets stored as the pair's control observations.

Shared by ``usvips target field`` and the window's *Find a target field…* tool. Three steps:

1. :func:`prepare` (or :func:`prepare_images` for two image files) reads what the search needs — the
   images, the control (metres), an earlier calibration's cameras when one is chosen, and the pair's
   stored control observations (the version read) — on the caller's thread;
2. :meth:`FieldJob.run` checks the clicks and runs :func:`usvips.core.target_field.find_field` in each
   image: a plain function of its inputs, so the window runs it on a worker thread;
3. :func:`confirm` stores the found targets (and the doubtful ones the user accepted or moved) seen in
   both images as the pair's control observations for its calibration role (``calibration-air`` for an
   in-air pair, ``calibration-water`` underwater), which the classic calibration reads.

Pixels: x right, y down, origin at the centre of the top-left pixel. Each side of a pair is searched on
its own: a target found in one image only is reported, never stored (an observation needs both).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from usvips.app.calibrations import read_calibration
from usvips.core.camera import Camera
from usvips.core.errors import DegenerateGeometryError, UsvipsError
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.target_field import LOCATORS, FieldSearch, clicks_needed, find_field
from usvips.io.images import read_image
from usvips.store.interface import ProjectStore
from usvips.store.versions import UNREAD

SIDES = ("left", "right")
STATUSES = ("found", "doubtful", "missing")
#: the calibration role of a pair's control observations, by the pair's medium
ROLES = {"air": "calibration-air", "water": "calibration-water"}

#: clicks per side: ``{"left": {id: (x, y)}, "right": {...}}`` (pixels)
Clicks = Mapping[str, Mapping[str, tuple[float, float]]]


class ClickError(UsvipsError):
    """The identified targets cannot start a search: too few, unknown ids, outside the image, coplanar
    where a DLT needs depth. The message names the image and the target; ``side`` and ``target`` (None
    when the problem is not one target's) let a caller point at the click."""

    def __init__(self, message: str, side: str, target: str | None = None) -> None:
        super().__init__(message)
        self.side = side
        self.target = target


@dataclass(frozen=True)
class FieldTarget:
    """One control point in one image: ``pixel`` as located (None when not), ``predicted`` where the
    model puts it (None behind the camera), ``status`` found | doubtful | missing, ``reason`` in words
    (why doubtful or missing), ``clicked`` when the user identified it, the locator's ``quality``."""

    id: str
    side: str
    pixel: tuple[float, float] | None
    predicted: tuple[float, float] | None
    status: str
    reason: str
    clicked: bool
    quality: float


@dataclass(frozen=True)
class SideResult:
    """Every control point's fate in one image, the RMS (px) of the found targets about the model, the
    locator's notes."""

    side: str
    targets: tuple[FieldTarget, ...]
    image_size: tuple[int, int]
    rms_px: float
    notes: tuple[str, ...] = ()

    def ids(self, status: str) -> tuple[str, ...]:
        return tuple(t.id for t in self.targets if t.status == status)

    def target(self, pid: str) -> FieldTarget:
        return next(t for t in self.targets if t.id == pid)

    def counts(self) -> dict[str, int]:
        return {status: len(self.ids(status)) for status in STATUSES}

    def advice(self) -> str:
        """A sentence when the identified targets disagree among themselves (empty otherwise)."""
        clicked = [t for t in self.targets if t.clicked]
        astray = [t.id for t in clicked if t.status == "doubtful" and "check its id" in t.reason]
        if len(astray) < 2:
            return ""
        return (f"{len(astray)} of the {len(clicked)} targets identified disagree with the others "
                f"({', '.join(astray)}): check their ids and places; with 8 or more identified, one wrong id is "
                "found and set aside")

    def summary(self) -> str:
        counts = self.counts()
        rms = "" if not np.isfinite(self.rms_px) else f" (RMS {self.rms_px:.2f} px)"
        return f"{counts['found']} found, {counts['doubtful']} doubtful, {counts['missing']} missing{rms}"


@dataclass(frozen=True)
class FieldResult:
    """Both images' searches of a pair, and what :func:`confirm` needs: the ``role`` its observations are
    stored under, the ``stored`` observations of that role as read (the version read) and the project's
    control as read (``stored_control``; the search's ``control`` is stored too when the project had none)."""

    pair: str
    role: str
    control: ControlPoints
    left: SideResult
    right: SideResult
    stored: StereoObservations | None = None
    stored_control: ControlPoints | None = None
    calibration_id: int | None = None

    def side(self, name: str) -> SideResult:
        return self.left if name == "left" else self.right

    def observations(self, accepted: Iterable[tuple[str, str]] = (),
                     moved: Mapping[tuple[str, str], tuple[float, float]] | None = None) -> StereoObservations:
        """The targets usable in both images, in control order: found, or doubtful and ``accepted`` as
        (side, id) with a pixel, or ``moved`` by the user ((side, id) → pixel, which accepts it)."""
        pixels = self._usable(accepted, moved)
        ids = tuple(pid for pid in self.control.ids if pid in pixels["left"] and pid in pixels["right"])
        return StereoObservations(ids, np.array([pixels["left"][i] for i in ids], float).reshape(-1, 2),
                                  np.array([pixels["right"][i] for i in ids], float).reshape(-1, 2),
                                  (self.pair,) * len(ids))

    def _usable(self, accepted: Iterable[tuple[str, str]] = (),
                moved: Mapping[tuple[str, str], tuple[float, float]] | None = None
                ) -> dict[str, dict[str, tuple[float, float]]]:
        """side → id → pixel of every target usable in that image (see :meth:`observations`)."""
        moved = dict(moved or {})
        accepted = set(accepted) | set(moved)
        pixels: dict[str, dict[str, tuple[float, float]]] = {}
        for side in SIDES:
            pixels[side] = {}
            for target in self.side(side).targets:
                key = (side, target.id)
                if key in moved:
                    pixels[side][target.id] = tuple(map(float, moved[key]))
                elif target.pixel is not None and (target.status == "found" or
                                                   (target.status == "doubtful" and key in accepted)):
                    pixels[side][target.id] = target.pixel
        return pixels

    def one_sided(self, accepted: Iterable[tuple[str, str]] = (),
                  moved: Mapping[tuple[str, str], tuple[float, float]] | None = None) -> tuple[str, ...]:
        """Ids usable (found, accepted or moved) in one image but not the other: never stored."""
        pixels = self._usable(accepted, moved)
        return tuple(pid for pid in self.control.ids if (pid in pixels["left"]) != (pid in pixels["right"]))


@dataclass(frozen=True)
class Confirmed:
    """What :func:`confirm` stored: the pair, the role, how many targets, whether the control was stored
    too, and the ids left out because they were usable in one image only."""

    pair: str
    role: str
    count: int
    control_stored: bool
    one_sided: tuple[str, ...]


@dataclass
class FieldJob:
    """Everything a search needs, read beforehand: the images (grey or RGB arrays), the control, the
    cameras of an earlier calibration (None: a DLT in air), the targets' ``shape`` (disc or cross)."""

    pair: str
    role: str
    control: ControlPoints
    images: dict[str, np.ndarray]
    cameras: dict[str, Camera] | None = None
    shape: str = "disc"
    stored: StereoObservations | None = None
    stored_control: ControlPoints | None = None
    calibration_id: int | None = None
    tolerance_px: float | None = None
    sources: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.shape not in LOCATORS:
            raise UsvipsError(f"unknown target shape {self.shape!r}; shapes: {', '.join(LOCATORS)}")
        if not len(self.control):
            raise UsvipsError("no control points: the field's coordinates (id, X, Y, Z in metres) are needed")

    def size(self, side: str) -> tuple[int, int]:
        image = self.images[side]
        return int(image.shape[1]), int(image.shape[0])

    def needed(self) -> int:
        """Targets to identify in each image (4 for a planar field, else 6)."""
        return clicks_needed(self.control)

    def caution(self) -> str:
        """A sentence when the model chosen is a poor fit: an underwater pair searched without a
        calibration (a DLT knows no refraction; its misfit makes more targets doubtful). Empty otherwise."""
        if self.role == ROLES["water"] and self.cameras is None:
            return ("an underwater pair without a calibration: the DLT ignores the refraction, so targets far from "
                    "the clicks may come out doubtful; an earlier calibration's housing models it")
        return ""

    def check(self, clicks: Clicks) -> None:
        """A :class:`ClickError` naming the first problem of the clicks, image by image."""
        for side in SIDES:
            check_side(self.control, side, dict(clicks.get(side, {})), self.size(side),
                       self.cameras is not None)

    def run(self, clicks: Clicks, progress: Callable[[float], None] | None = None,
            cancelled: Callable[[], bool] | None = None) -> FieldResult | None:
        """Check the clicks, then search each image; None as soon as ``cancelled()`` is true (asked before
        each target is located)."""
        self.check(clicks)
        results = {}
        for k, side in enumerate(SIDES):
            if cancelled is not None and cancelled():
                return None
            if progress is not None:
                progress(k / len(SIDES))
            options = {} if self.tolerance_px is None else {"tolerance_px": self.tolerance_px}
            camera = None if self.cameras is None else self.cameras[side]
            try:
                search = find_field(self.images[side], self.control, dict(clicks[side]), camera, shape=self.shape,
                                    cancelled=cancelled, **options)
            except DegenerateGeometryError as error:
                raise ClickError(f"{side} image: {error}", side) from None
            except InterruptedError:
                return None
            results[side] = side_result(side, search)
        if progress is not None:
            progress(1.0)
        return FieldResult(self.pair, self.role, self.control, results["left"], results["right"], self.stored,
                           self.stored_control, self.calibration_id)


def side_result(side: str, search: FieldSearch) -> SideResult:
    """The core's search of one image as the service's typed result."""
    targets = tuple(FieldTarget(p.id, side, p.pixel, p.predicted, p.status, _reason(p.status, p.reason), p.clicked,
                                float(p.quality)) for p in search.points)
    return SideResult(side, targets, search.image_size, float(search.rms_px), tuple(search.notes))


def _reason(status: str, reason: str) -> str:
    if status == "found" or reason:
        return reason
    return "not located" if status == "missing" else "check it"


def inside(pixel: tuple[float, float], size: tuple[int, int]) -> bool:
    """Whether ``pixel`` lies on an image of ``size`` (width, height): x from −0.5 to width − 0.5, y alike."""
    x, y = (float(v) for v in pixel)
    width, height = size
    return bool(np.isfinite(x) and np.isfinite(y) and -0.5 <= x <= width - 0.5 and -0.5 <= y <= height - 0.5)


def check_side(control: ControlPoints, side: str, clicks: Mapping[str, tuple[float, float]], size: tuple[int, int],
               calibrated: bool) -> None:
    """The clicks of one image, checked in the order a user fixes them: unknown ids, pixels outside the
    image, too few, all in one plane where a DLT needs depth (no earlier calibration, a 3-D field)."""
    known = set(control.ids)
    for pid, pixel in clicks.items():
        if pid not in known:
            shown = ", ".join(control.ids[:6]) + (" …" if len(control) > 6 else "")
            raise ClickError(f"{side} image: target {pid!r} is not a control point (the control's ids: {shown})",
                             side, pid)
        x, y = (float(v) for v in pixel)
        width, height = size
        if not inside((x, y), size):
            raise ClickError(f"{side} image: target {pid!r} at ({x:g}, {y:g}) lies outside the image ({width} × "
                             f"{height} px)", side, pid)
    needed = clicks_needed(control)
    if len(clicks) < needed:
        more = needed - len(clicks)
        raise ClickError(f"{side} image: {len(clicks)} target{'s' * (len(clicks) != 1)} identified; at least "
                         f"{needed} are needed ({more} more)", side)
    if needed > 4 and not calibrated:
        xyz = control.xyz[control.index_of(list(clicks))]
        singular = np.linalg.svd(xyz - xyz.mean(axis=0), compute_uv=False)
        if singular[0] == 0 or singular[2] / singular[0] < 1e-3:
            raise ClickError(f"{side} image: the {len(clicks)} targets identified lie in one plane of the field; "
                             "without a calibration the model needs depth: identify targets off that plane "
                             "(or search with an earlier calibration)", side)


# ------------------------------------------------------------------------------------------ preparing
def prepare(project: ProjectStore, pair: str, control: ControlPoints | None = None, calibration_id: int | None = None,
            shape: str = "disc") -> FieldJob:
    """A search of the project's image pair ``pair``: its images, the project's control (or ``control``
    when the project has none; a different one is refused), the cameras of the stored calibration
    ``calibration_id`` (None: a DLT in air), and the pair's stored observations of its role as read."""
    rows = {p.label: p for p in project.pairs()}
    if pair not in rows:
        shown = ", ".join(list(rows)[:8]) or "none"
        raise UsvipsError(f"{project.path}: no image pair {pair!r} (pairs: {shown})")
    row = rows[pair]
    if not row.left or not row.right:
        raise UsvipsError(f"{project.path}: pair {pair!r} has no images (a video frame pair? export it first)")
    stored_control = project.control()
    chosen = _control(project, stored_control, control)
    role = ROLES.get(row.medium or "water", "calibration-water")
    stored = project.control_observations(role, pair)
    paths = {side: project.image_path(getattr(row, side)) for side in SIDES}
    images = {side: read_image(paths[side]) for side in SIDES}
    cameras = cameras_of(project, calibration_id, pair)
    return FieldJob(pair, role, chosen, images, cameras, shape, stored, stored_control, calibration_id,
                    sources={side: str(paths[side]) for side in SIDES})


def cameras_of(project: ProjectStore, calibration_id: int | None, pair: str) -> dict[str, Camera] | None:
    """The left and right cameras of the stored calibration ``calibration_id`` (None: None), placed at
    ``pair``'s station when it is one (else the first: the pose is only a start, it is resected)."""
    if calibration_id is None:
        return None
    calibration = read_calibration(project, calibration_id)
    rig = calibration.rig(pair if pair in calibration.stations else 0)
    return {"left": rig.left, "right": rig.right}


def _control(project: ProjectStore, stored: ControlPoints, given: ControlPoints | None) -> ControlPoints:
    if given is None:
        if not len(stored):
            raise UsvipsError(f"{project.path}: the project holds no control points; give the field's control "
                              "(id, X, Y, Z in metres)")
        return stored
    if len(stored) and not same_control(stored, given):
        raise UsvipsError(f"{project.path}: the project already holds other control points than "
                          f"{given.source or 'the control given'}; search with the project's control")
    return given


def same_control(a: ControlPoints, b: ControlPoints, tolerance_m: float = 1e-6) -> bool:
    """The same ids with the same coordinates (within ``tolerance_m`` metres), in any order."""
    if set(a.ids) != set(b.ids):
        return False
    return bool(np.all(np.abs(a.xyz - b.xyz[b.index_of(list(a.ids))]) <= tolerance_m))


def prepare_images(left: str | Path, right: str | Path, control: ControlPoints, cameras: Mapping[str, Camera] | None,
                   shape: str = "disc", label: str = "pair", medium: str = "air") -> FieldJob:
    """A search of two image files (no project; ``medium`` "air" or "water" names the role its
    observations would have): the result's :meth:`FieldResult.observations` are for the caller to write."""
    if medium not in ROLES:
        raise UsvipsError(f"medium {medium!r}: air or water")
    paths = {"left": Path(left), "right": Path(right)}
    images = {side: read_image(paths[side]) for side in SIDES}
    return FieldJob(label, ROLES[medium], control, images, None if cameras is None else dict(cameras), shape,
                    sources={side: str(paths[side]) for side in SIDES})


# ------------------------------------------------------------------------------------------ confirming
def confirm(project: ProjectStore, result: FieldResult, accepted: Iterable[tuple[str, str]] = (),
            moved: Mapping[tuple[str, str], tuple[float, float]] | None = None) -> Confirmed:
    """Store the targets usable in both images (:meth:`FieldResult.observations`) as the pair's control
    observations for its role, replacing those of the same ids and keeping the others, in one transaction
    named on the version read (a set changed since by someone else is refused, nothing stored); the
    control too when the project had none."""
    accepted = set(accepted)
    for side, pid in accepted:
        target = result.side(side).target(pid) if pid in result.control.ids else None
        if target is None or target.status != "doubtful":
            raise UsvipsError(f"{side} image: target {pid!r} is not doubtful: only a doubtful target can be accepted")
        if target.pixel is None and (side, pid) not in (moved or {}):
            raise UsvipsError(f"{side} image: target {pid!r} was not located ({target.reason}): place it before "
                              "accepting it")
    for (side, pid), pixel in (moved or {}).items():
        if not inside(pixel, result.side(side).image_size):
            raise UsvipsError(f"{side} image: target {pid!r} placed at ({pixel[0]:g}, {pixel[1]:g}), outside the "
                              "image")
    new = result.observations(accepted, moved)
    if not len(new):
        raise UsvipsError(f"pair {result.pair!r}: no target is usable in both images; nothing stored")
    stored = result.stored if result.stored is not None else StereoObservations((), np.zeros((0, 2)), np.zeros((0, 2)))
    expected = UNREAD if result.stored is None else result.stored
    keep = [i for i, pid in enumerate(stored.ids) if pid not in set(new.ids)]
    merged = StereoObservations(tuple(stored.ids[i] for i in keep) + new.ids,
                                np.vstack([stored.left[keep], new.left]), np.vstack([stored.right[keep], new.right]),
                                (result.pair,) * (len(keep) + len(new)))
    control_stored = result.stored_control is not None and not len(result.stored_control)
    with project.transaction():
        if control_stored:
            project.set_control(result.control, expected=result.stored_control)
        project.add_control_observations(merged, result.role, result.pair, replace=True, expected=expected)
    return Confirmed(result.pair, result.role, len(new), control_stored, result.one_sided(accepted, moved))
