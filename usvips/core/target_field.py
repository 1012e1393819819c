"""Finding the rest of a 3-D target field from a few targets the user identified.

A field of discs or crosses (a cube, the thesis's frame) is known by its control file; the user clicks
six or more of its targets in an image and names them. From those, every other target's pixel is
predicted and snapped with the sub-pixel locators of :mod:`usvips.core.targets`:

* **In air, no calibration**: a DLT of the image from the clicked targets (:mod:`usvips.core.dlt`; they
  must not be coplanar). A planar field takes a homography instead (four or more clicks).
* **An earlier calibration** (a :class:`~usvips.core.camera.Camera`, through its housing for an
  underwater image): the camera's pose is resected from the clicked targets with its interior and
  housing held (least squares on the six exterior parameters from a PnP start), and every target is
  projected through the housing.

The clicks are snapped first and the model fitted to them robustly (a robust DLT from eight clicks on,
a Cauchy loss in a resection), so that one click under the wrong id does not spoil it; the model is then
refitted from all targets found (``rounds`` times), leaving out clicks far from where the others put
them, and the rest predicted again, so that a DLT's neglect of lens distortion shrinks to the local
misfit. Each target ends as:

* ``found``: snapped (a good quality, one candidate) within the tolerance of its prediction;
* ``doubtful``: snapped, but far from its prediction, of low quality, sharing its target with another
  id, or the locator saw two targets there (or one running out of its window); a click far from where
  the other targets put it ("check its id") — for the user to confirm or move;
* ``missing``: predicted outside the image or behind the camera, or the locator found nothing there.

Pixels: x right, y down, origin at the centre of the top-left pixel; control in metres.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.optimize import least_squares

from usvips.core import dlt as dlt_module
from usvips.core.calibration_targets.detection import StereoView, TargetDetection
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.observations import ControlPoints
from usvips.core.rotation import angles_from_matrix
from usvips.core.targets import TargetResult, locate_cross, locate_disc

#: the locators by target shape
LOCATORS = {"disc": locate_disc, "cross": locate_cross}
#: a snapped target this far (pixels) from its prediction is doubtful (or farther, when the model's own
#: misfit is larger: see :func:`find_field`)
TOLERANCE_PX = 2.0
#: a disc whose contrast-to-noise is below this, or a cross whose correlation is below its share of 1,
#: is doubtful
MINIMUM_QUALITY = {"disc": 12.0, "cross": 0.7}
#: clicks needed: the DLT's minimum (a planar field's homography needs four)
MINIMUM_CLICKS = 6


@dataclass(frozen=True)
class FieldPoint:
    """One control point in one image: ``predicted`` pixel (None when behind the camera), ``pixel`` as
    snapped (None when not found), the locator's ``quality``, ``status`` found | doubtful | missing,
    ``clicked`` when the user identified it, and ``reason`` (why doubtful or missing)."""

    id: str
    predicted: tuple[float, float] | None
    pixel: tuple[float, float] | None
    quality: float
    status: str
    clicked: bool = False
    reason: str = ""

    def __bool__(self) -> bool:
        """Falsy unless the point was found (doubtful or missing: ``reason`` says why)."""
        return self.status == "found" and self.pixel is not None


@dataclass(frozen=True)
class FieldSearch:
    """Every control point's fate in one image, the model used (``camera``: the resected camera, or None
    for a DLT/homography, then ``matrix``: its 3 × 4 projection, or 3 × 3 homography of the field's
    plane), the RMS (px) of the found targets about the final prediction, and notes."""

    points: tuple[FieldPoint, ...]
    image_size: tuple[int, int]
    camera: Camera | None
    matrix: np.ndarray | None
    rms_px: float
    notes: tuple[str, ...] = field(default_factory=tuple)

    def ids(self, status: str) -> tuple[str, ...]:
        return tuple(p.id for p in self.points if p.status == status)

    def detection(self, include_doubtful: bool = False) -> TargetDetection:
        """The found targets (and the doubtful ones, if asked) as a detection, quality as the locator's."""
        keep = [p for p in self.points if p.status == "found" or (include_doubtful and p.status == "doubtful"
                                                                   and p.pixel is not None)]
        if not keep:
            return TargetDetection.nothing(self.image_size, "no target of the field found")
        return TargetDetection(tuple(p.id for p in keep), np.array([p.pixel for p in keep]),
                               np.array([p.quality for p in keep]), self.image_size, notes=self.notes)

    def summary(self) -> str:
        return (f"{len(self.ids('found'))} found, {len(self.ids('doubtful'))} doubtful, "
                f"{len(self.ids('missing'))} missing (RMS {self.rms_px:.2f} px)")


# ---------------------------------------------------------------------------------------------- models
class _Model(ABC):
    """Predicts pixels of control points: ``predict(xyz) -> (pixels (N, 2), visible (N,))``."""

    camera: Camera | None = None
    matrix: np.ndarray | None = None

    @abstractmethod
    def predict(self, xyz: np.ndarray, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (N, 2) of control points ``xyz`` (N, 3) m in an image of ``size`` (width, height) px,
        and which of them are visible (N,)."""


class _Projective(_Model):
    def __init__(self, xyz: np.ndarray, pixels: np.ndarray, planar_frame, robust: bool = False) -> None:
        self.frame = planar_frame
        if planar_frame is None:
            # from the clicks alone: a DLT that one misnamed click cannot spoil (it needs eight or more)
            self.matrix = (dlt_module.robust_dlt if robust else dlt_module.dlt)(xyz, pixels).matrix
        else:
            homography, _ = cv2.findHomography(self._plane(xyz), pixels, cv2.LMEDS if robust and len(xyz) > 5 else 0)
            if homography is None:
                raise DegenerateGeometryError("the clicked targets do not fix a homography (three in a line?)")
            self.matrix = homography

    def _plane(self, xyz: np.ndarray) -> np.ndarray:
        centre, axes = self.frame
        return (xyz - centre) @ axes[:2].T

    def predict(self, xyz, size):
        if self.frame is None:
            homogeneous = np.column_stack([xyz, np.ones(len(xyz))]) @ self.matrix.T
        else:
            homogeneous = np.column_stack([self._plane(xyz), np.ones(len(xyz))]) @ self.matrix.T
        depth = homogeneous[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            pixels = homogeneous[:, :2] / depth[:, None]
        visible = depth > 0 if self.frame is None else np.sign(depth) == np.sign(np.median(depth))
        return pixels, visible & np.all(np.isfinite(pixels), axis=1)


class _Resected(_Model):
    """A calibrated camera (interior and housing held) whose exterior is resected from the targets. With
    ``robust`` (the clicks alone) the start is a RANSAC PnP and only its inliers are fitted, so that a click
    under the wrong id does not pull the pose."""

    def __init__(self, camera: Camera, xyz: np.ndarray, pixels: np.ndarray, start: Exterior | None = None,
                 robust: bool = False) -> None:
        if start is None or robust:
            start, inliers = _pnp_start(camera, xyz, pixels, robust)
            xyz, pixels = xyz[inliers], pixels[inliers]
        names = ("X0", "Y0", "Z0", "omega", "phi", "kappa")
        x0 = np.array([getattr(start, n) for n in names])
        free = Camera(camera.interior, start, camera.housing)  # no frame check: a click may sit on the edge

        def residuals(values: np.ndarray) -> np.ndarray:
            projection = free.with_exterior(Exterior(*values)).project(xyz)
            out = projection.pixels - pixels
            out[~projection.ok] = 1e3  # a target the trial pose cannot see
            return out.ravel()

        fit = least_squares(residuals, x0, method="lm", x_scale=np.array([0.01, 0.01, 0.01, 1e-3, 1e-3, 1e-3]))
        self.camera = camera.with_exterior(Exterior(*fit.x))

    def predict(self, xyz, size):
        free = Camera(self.camera.interior, self.camera.exterior, self.camera.housing)  # no frame check here
        projection = free.project(xyz)
        return projection.pixels, projection.ok


#: RANSAC's threshold on the clicks in normalised coordinates (the housing's refraction is not modelled
#: in the start: a flat port's misfit reaches about 1 % of the focal length; a misnamed click is far more)
_START_THRESHOLD = 0.02


def _pnp_start(camera: Camera, xyz: np.ndarray, pixels: np.ndarray, robust: bool) -> tuple[Exterior, np.ndarray]:
    """A pose from OpenCV's PnP on the clicked pixels undistorted by the interior (the housing's
    refraction ignored: a start only), and which clicks agree with it (all, unless ``robust``)."""
    uv = camera.interior.pixels_to_normalised(pixels)
    image = np.column_stack([uv[:, 0], -uv[:, 1]]).reshape(-1, 1, 2)  # our camera frame (y up, z back) → OpenCV's
    objects = xyz.reshape(-1, 1, 3)
    inliers = np.ones(len(xyz), bool)
    ok, rvec, tvec = cv2.solvePnP(objects, image, np.eye(3), None, flags=cv2.SOLVEPNP_SQPNP)
    if robust and len(xyz) >= 6:
        found, r_ransac, t_ransac, index = cv2.solvePnPRansac(
            objects, image, np.eye(3), None, iterationsCount=200, reprojectionError=_START_THRESHOLD,
            confidence=0.999, flags=cv2.SOLVEPNP_EPNP)
        if found and index is not None and len(index) >= 6:
            inliers = np.zeros(len(xyz), bool)
            inliers[index.ravel()] = True
            ok, rvec, tvec = cv2.solvePnP(objects[inliers], image[inliers], np.eye(3), None,
                                          flags=cv2.SOLVEPNP_SQPNP)
    if not ok:
        raise DegenerateGeometryError("the clicked targets do not fix the camera's pose")
    rotation = cv2.Rodrigues(rvec)[0]
    centre = -rotation.T @ tvec.ravel()
    return Exterior(*centre, *angles_from_matrix(dlt_module.FLIP @ rotation)), inliers


def clicks_needed(control: ControlPoints) -> int:
    """How many targets must be identified in an image of the field: four for a planar field (a
    homography), six otherwise (a DLT, or a resection of an earlier calibration's camera)."""
    return 4 if _planar_frame(control.xyz) is not None else MINIMUM_CLICKS


def _planar_frame(xyz: np.ndarray):
    centre = xyz.mean(axis=0)
    _, singular, axes = np.linalg.svd(xyz - centre)
    planar = singular[0] == 0 or singular[2] / singular[0] < 1e-3
    return (centre, axes) if planar else None


# ---------------------------------------------------------------------------------------------- search
def _clicks(control: ControlPoints, clicks, what: str) -> tuple[tuple[str, ...], np.ndarray]:
    if isinstance(clicks, Mapping):
        ids, pixels = tuple(str(k) for k in clicks), np.array([clicks[k] for k in clicks], dtype=np.float64)
    else:
        ids, pixels = tuple(str(k) for k in clicks[0]), np.asarray(clicks[1], dtype=np.float64)
    pixels = pixels.reshape(-1, 2)
    if len(ids) != len(pixels):
        raise InvalidParameterError(what, f"{len(ids)} ids but {len(pixels)} pixels")
    if len(set(ids)) != len(ids):
        raise InvalidParameterError(what, "a target is identified twice")
    if not np.all(np.isfinite(pixels)):
        raise InvalidParameterError(what, "a clicked pixel is not a finite number")
    control.index_of(ids, "identified target")
    return ids, pixels


def _snap(image: np.ndarray, pixel: np.ndarray, size: tuple[int, int], shape: str, window: int,
          least: int) -> TargetResult:
    """The locator at ``pixel``; near the image's edge with a window shrunk to fit (down to ``least``)."""
    width, height = size
    if not (np.all(np.isfinite(pixel)) and -0.5 <= pixel[0] < width - 0.5 and -0.5 <= pixel[1] < height - 0.5):
        return TargetResult(None, 0.0, "predicted outside the image")
    col, row = int(round(float(pixel[0]))), int(round(float(pixel[1])))
    room = min(col, row, width - 1 - col, height - 1 - row) - 1
    half = min(window // 2, room)
    if half < least // 2:
        return TargetResult(None, 0.0, "too near the image edge to locate")
    return LOCATORS[shape](image, (float(pixel[0]), float(pixel[1])), 2 * half + 1)


def find_field(image: np.ndarray, control: ControlPoints, clicks, camera: Camera | None = None,
               shape: str = "disc", window: int | None = None, tolerance_px: float = TOLERANCE_PX,
               rounds: int = 1, cancelled: Callable[[], bool] | None = None) -> FieldSearch:
    """Find every target of ``control`` in ``image`` from the user's ``clicks`` (a mapping id → (x, y), or
    (ids, pixels (N, 2))), see the module's notes.

    ``camera``: an earlier calibration's camera for this image (its exterior is only a start if the
    clicks cannot give one; its interior and housing are held); None in air for a DLT. ``shape``: the
    targets' kind, "disc" or "cross". ``window`` (px) of the locator; by default from the clicked targets'
    size (discs: four times their radius plus 16 px, at least 21; crosses 41). ``tolerance_px``: a target
    further than this from its prediction is doubtful (without a camera, an uncalibrated lens: or than four
    times the robust spread of the found targets about the DLT, when larger, up to three times the
    tolerance). ``cancelled()`` is asked before each target is located: True raises
    :class:`InterruptedError`."""
    if shape not in LOCATORS:
        raise InvalidParameterError("shape", f"unknown target shape {shape!r}; known: {', '.join(LOCATORS)}")
    if not tolerance_px > 0:
        raise InvalidParameterError("tolerance_px", f"must be positive, got {tolerance_px}")
    image = np.asarray(image)
    size = (int(image.shape[1]), int(image.shape[0]))
    ids, pixels = _clicks(control, clicks, "clicks")
    planar = _planar_frame(control.xyz)
    minimum = 4 if planar is not None else MINIMUM_CLICKS
    if len(ids) < minimum:
        raise DegenerateGeometryError(f"identify at least {minimum} targets of the field, got {len(ids)}")
    xyz_all = control.xyz
    notes: list[str] = []
    # the clicks snapped first; a click the locator refuses stays as clicked
    probe = 41 if window is None else int(window)
    least = 17 if shape == "disc" else 21  # a cross's window must hold its 15 px template and the peak's fit
    stop = _stopper(cancelled)
    snapped = [stop() or _snap(image, p, size, shape, probe, least) for p in pixels]
    click_pixels = np.array([r.center if r else p for r, p in zip(snapped, pixels, strict=True)], dtype=np.float64)
    radii = [r.radius for r in snapped if r and r.radius > 0]
    if window is None:
        window = max(21, int(4 * np.median(radii) + 16)) | 1 if (radii and shape == "disc") else 41
    if radii and shape == "disc":
        least = max(least, int(2 * np.median(radii) + 11) | 1)  # the disc and its edge band inside the window
    for pid, r in zip(ids, snapped, strict=True):
        if not r:
            notes.append(f"target {pid} as clicked: {r.reason}")
    clicked_index = control.index_of(ids)
    if camera is None and planar is None:
        dlt_module.check_spread(xyz_all[clicked_index], MINIMUM_CLICKS, "identified targets")
    fit_index, fit_pixels = clicked_index, click_pixels
    results: list[TargetResult] = []
    predicted = visible = None
    model: _Model | None = None
    for round_ in range(max(1, int(rounds)) + 1):
        first = round_ == 0
        model = (_Resected(camera, xyz_all[fit_index], fit_pixels, None if model is None else model.camera.exterior,
                           robust=first)
                 if camera is not None else _Projective(xyz_all[fit_index], fit_pixels, planar, robust=first))
        predicted, visible = model.predict(xyz_all, size)
        results = [stop() or _snap(image, p, size, shape, window, least) if v
                   else TargetResult(None, 0.0, "behind the camera")
                   for p, v in zip(predicted, visible, strict=True)]
        good = np.array([bool(r) for r in results])
        good[clicked_index] = True
        located = np.array([r.center if r else (np.nan, np.nan) for r in results], dtype=np.float64)
        located[clicked_index] = click_pixels
        limit = _limit(located, predicted, good, tolerance_px, camera is None)
        near = good & (np.linalg.norm(located - predicted, axis=1) <= limit)
        fit_index = np.flatnonzero(near)  # a click far from where the others put it is left out of the next fit
        if len(fit_index) < minimum + 2:
            fit_index = clicked_index
        fit_pixels = located[fit_index]
    points, rms = _classify(control, ids, clicked_index, click_pixels, snapped, predicted, visible, results,
                            tolerance_px, shape, camera is None)
    return FieldSearch(tuple(points), size, model.camera, model.matrix, rms, tuple(notes))


def _stopper(cancelled: Callable[[], bool] | None) -> Callable[[], None]:
    """A call that raises :class:`InterruptedError` once ``cancelled()`` is true (never without one)."""
    def stop() -> None:
        if cancelled is not None and cancelled():
            raise InterruptedError("the search of the target field was stopped")
    return stop


def _limit(located: np.ndarray, predicted: np.ndarray, good: np.ndarray, tolerance_px: float,
           adaptive: bool) -> float:
    """The distance (px) from its prediction beyond which a target is doubtful: the tolerance, or (for an
    uncalibrated lens, ``adaptive``) four times the robust spread (1.4826 · median distance) of the
    located targets when larger, up to three times the tolerance."""
    if not adaptive:
        return tolerance_px
    distances = np.linalg.norm(located[good] - predicted[good], axis=1)
    distances = distances[np.isfinite(distances)]
    spread = 1.4826 * float(np.median(distances)) if len(distances) else 0.0
    return min(max(tolerance_px, 4.0 * spread), 3.0 * tolerance_px)


def _classify(control, ids, clicked_index, click_pixels, snapped, predicted, visible, results, tolerance_px, shape,
              adaptive):
    clicked = dict(zip(clicked_index.tolist(), range(len(ids)), strict=True))
    located = np.array([r.center if r else (np.nan, np.nan) for r in results], dtype=np.float64)
    good = np.array([bool(r) for r in results])
    limit = _limit(located, predicted, good, tolerance_px, adaptive)
    # two ids snapped onto one target: both doubtful
    shared = np.zeros(len(results), bool)
    rows = np.flatnonzero(good)
    if len(rows) > 1:
        d = np.linalg.norm(located[rows, None] - located[None, rows], axis=2)
        np.fill_diagonal(d, np.inf)
        shared[rows[np.any(d < 1.0, axis=1)]] = True
    points, residuals = [], []
    for i, pid in enumerate(control.ids):
        prediction = tuple(float(v) for v in predicted[i]) if visible[i] else None
        if i in clicked:
            k = clicked[i]
            quality = snapped[k].quality if snapped[k] else 0.0
            pixel = tuple(float(v) for v in click_pixels[k])
            reasons = [] if snapped[k] else [f"as clicked ({snapped[k].reason})"]
            off = float(np.hypot(pixel[0] - prediction[0], pixel[1] - prediction[1])) if prediction else np.inf
            if prediction is None:
                reasons.append("clicked, but the other targets put it behind the camera: check its id")
            elif off > limit:
                reasons.append(f"clicked, but {off:.1f} px from where the other targets put it: check its id")
            points.append(FieldPoint(pid, prediction, pixel, quality, "doubtful" if reasons else "found", True,
                                     "; ".join(reasons)))
            continue
        result = results[i]
        if not visible[i] or not result:
            # two targets in the window, or one running out of it: something is there, for the user to judge
            status = "doubtful" if result.reason.startswith(("two ", "clipped: the target")) else "missing"
            points.append(FieldPoint(pid, prediction, None, result.quality, status, False,
                                     result.reason or "not in view"))
            continue
        pixel = tuple(float(v) for v in result.center)
        distance = float(np.hypot(pixel[0] - prediction[0], pixel[1] - prediction[1]))
        reasons = []
        if distance > limit:
            reasons.append(f"{distance:.1f} px from its prediction")
        if result.quality < MINIMUM_QUALITY[shape]:
            reasons.append(f"low quality ({result.quality:.2g})")
        if shared[i]:
            reasons.append("another target's id snapped to the same place")
        if not reasons:
            residuals.append(distance)
        points.append(FieldPoint(pid, prediction, pixel, float(result.quality), "doubtful" if reasons else "found",
                                 False, "; ".join(reasons)))
    rms = float(np.sqrt(np.mean(np.square(residuals)))) if residuals else float("nan")
    return points, rms


def find_field_pair(left_image: np.ndarray, right_image: np.ndarray, control: ControlPoints, left_clicks,
                    right_clicks, cameras: Sequence[Camera] | None = None, label: str = "pair",
                    **options) -> tuple[StereoView, FieldSearch, FieldSearch]:
    """:func:`find_field` in both images of a pair (``cameras``: the left and right cameras of an earlier
    calibration, or None in air); the found targets as a :class:`StereoView` for the calibration, and both
    searches for the user to confirm."""
    left_camera, right_camera = (None, None) if cameras is None else tuple(cameras)
    left = find_field(left_image, control, left_clicks, left_camera, **options)
    right = find_field(right_image, control, right_clicks, right_camera, **options)
    view = StereoView(label, left.detection(), right.detection(), {"pair": label})
    return view, left, right
