"""Intersection with the calibration's own uncertainty propagated into every point.

The pixel part of a point's covariance comes from the pointing precision of its pixels (``pointing_sigma_px``,
px per image coordinate, :mod:`usvips.core.pointing`; ``intersection.py``). A
calibration estimated from few control points is itself uncertain, and that error is common to every
point measured with it: its part is J Σ Jᵀ, with Σ the calibration's a-posteriori covariance of its free
parameters and J = ∂point/∂parameter by forward differences (re-intersecting with each parameter stepped
by the model's step, ``model._STEPS``).

The differences are batched. The cameras with one parameter stepped do not depend on the picks: they are
built once per (calibration, station, frame) and kept (:func:`stepped_cameras`). A pick then only moves its
rays. A step of a camera's pose moves its traced rays rigidly, with no new trace. A step of the principal
distance, the principal point or the y scale (the affine map of pixels to image coordinates, ahead of the
lens distortion) reads, through the same lens and housing, what the calibration's camera reads at other
pixels: those are traced for all such steps at once, and their pixel derivatives carried through the
affine map. Any other step (distortion, housing) retraces the pixels through the stepped camera. All
stepped rays are intersected in one call. The derivatives of a few rows (a pick's vertex) are kept: the
figures of the object stored from those picks then need no stepped ray at all (each row's derivatives
depend on that row's pixels alone: a new computation gives them again but for rounding, ~1e-8 relative,
from the undistortion's Newton iterations, which run until every row of a call has converged).
:func:`reference_derivatives` is the plain loop (rebuild, retrace,
re-intersect per parameter) the batched path is tested against.
"""

from __future__ import annotations

import threading
import weakref
from dataclasses import dataclass, replace

import numpy as np

from usvips.core.calibration.model import _STEPS, stereo_cameras
from usvips.core.calibration.parameter_names import symbol
from usvips.core.camera import EXTERIOR_PARAMETERS, Camera
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.interior import Interior
from usvips.core.intersection import Intersection, TracedRays, intersect_traced, retrace, trace
from usvips.core.pointing import per_vertex
from usvips.core.rays import RayBundle
from usvips.core.stereo_calibration import StereoCalibration

#: rows (stepped parameters × points) intersected in one call: bounds the memory of a large batch
BATCH_ROWS = 200_000
#: calibrations (with their station and frame) whose stepped cameras are kept
KEPT = 8
#: rows (one vertex's pixels) whose derivatives are kept, from calls of at most :data:`FEW_ROWS` rows
KEPT_ROWS = 64
FEW_ROWS = 16

#: how a step moves one camera: not at all; its pose and/or its affine pixel map (:data:`AFFINE`) only, so
#: that its rays follow from the calibration camera's; or otherwise (a new trace)
UNMOVED, MAPPED, RETRACE = 0, 1, 2
#: the interior parameters of the affine map pixels → image coordinates (x̄ = x − xp, ȳ = (yp − y)·sy),
#: divided by f into the distorted normalised coordinates
AFFINE = ("f", "xp", "yp", "sy")


@dataclass(frozen=True)
class SteppedColumn:
    """One free parameter of the calibration's covariance stepped: its row ``index`` in the covariance,
    the ``step`` (parameter units), the two cameras with it stepped and how each moved (``UNMOVED``,
    ``MAPPED``, ``RETRACE``)."""

    index: int
    step: float
    cameras: tuple[Camera, Camera]
    moved: tuple[int, int]


def _station_label(calibration: StereoCalibration, station: int | str) -> str:
    return calibration.stations[calibration.station_index(station)]


def intersect_with_calibration(calibration: StereoCalibration, left: np.ndarray, right: np.ndarray,
                               station: int | str = 0, frame: str = "object",
                               include_calibration: bool = True,
                               pointing_sigma_px: float | np.ndarray | None = None) -> Intersection:
    """Intersect conjugate pixels (N, 2) with a calibrated rig; covariance = pointing + calibration.

    ``pointing_sigma_px``: the pixels' pointing precision (px, one coordinate): a scalar, (N,) per point or
    (N, 2) [left, right] per point. None: the calibration's a-posteriori sigma0 — right for observations
    of the kind the calibration was adjusted from (its own corners or targets), NOT for a person's picks:
    the figure path (``usvips.core.measurements``) always passes the picks' own pointing sigma. Where the
    calibration has no parameter covariance (e.g. imported from OpenCV), only the pointing part is given.
    """
    result, derivatives, sigma = _intersect_and_derivatives(calibration, left, right, station, frame,
                                                            include_calibration, pointing_sigma_px)
    if derivatives is None:
        return result
    calibration_part = np.einsum("jni,jk,knl->nil", derivatives, sigma, derivatives, optimize=True)
    covariance = result.covariance + np.where(result.ok[:, None, None], calibration_part, 0.0)
    return Intersection(result.points, covariance, result.residuals_m, result.residuals_px, result.status)


def joint_covariance(calibration: StereoCalibration, left: np.ndarray, right: np.ndarray,
                     station: int | str = 0, frame: str = "object",
                     pointing_sigma_px: float | np.ndarray | None = None) -> tuple[Intersection, np.ndarray]:
    """The intersection and the full (3N, 3N) covariance of all its points: the pointing part per point,
    and the calibration's part between every pair of points (a common calibration error correlates
    them; a length between two points partly cancels it). ``pointing_sigma_px`` as in
    :func:`intersect_with_calibration`."""
    result, pointing, calibration_part = covariance_parts(calibration, left, right, station, frame,
                                                          pointing_sigma_px)
    return result, pointing + calibration_part


def covariance_parts(calibration: StereoCalibration, left: np.ndarray, right: np.ndarray,
                     station: int | str = 0, frame: str = "object",
                     pointing_sigma_px: float | np.ndarray | None = None
                     ) -> tuple[Intersection, np.ndarray, np.ndarray]:
    """The intersection and the two parts of its joint (3N, 3N) covariance (m²), which add up to
    :func:`joint_covariance`'s: the pointing part (block diagonal: each point's pixels' pointing sigmas)
    and the calibration's part (J Σ Jᵀ over all points; zero without a parameter covariance)."""
    result, derivatives, sigma = _intersect_and_derivatives(calibration, left, right, station, frame, True,
                                                            pointing_sigma_px)
    n = len(result.points)
    pointing = np.zeros((3 * n, 3 * n))
    for i in range(n):
        pointing[3 * i:3 * i + 3, 3 * i:3 * i + 3] = result.covariance[i]
    calibration_part = np.zeros((3 * n, 3 * n))
    if derivatives is not None:
        flat = derivatives.reshape(len(derivatives), 3 * n)
        calibration_part = flat.T @ sigma @ flat
    return result, pointing, calibration_part


def intersection_derivatives(calibration: StereoCalibration, left: np.ndarray, right: np.ndarray,
                             station: int | str = 0, frame: str = "object",
                             pointing_sigma_px: float | np.ndarray | None = None
                             ) -> tuple[Intersection, np.ndarray | None, np.ndarray | None]:
    """The intersection of many points at once with the derivatives (P, N, 3) of each point by each free
    parameter of the calibration's covariance Σ (P, P), or None and None without a usable covariance:
    what :func:`covariance_parts` builds its (3N, 3N) parts from, for callers that need the parts of many
    small sets of points (each object's vertices) without the whole matrix. Each point's row depends on
    its own pixels alone. ``pointing_sigma_px`` as in :func:`intersect_with_calibration`."""
    return _intersect_and_derivatives(calibration, left, right, station, frame, True, pointing_sigma_px)


def _pointing(calibration: StereoCalibration, left: np.ndarray, pointing_sigma_px) -> np.ndarray:
    """(N, 2) pointing sigmas (px) [left, right] of N points: σ0 when None, else as given (checked)."""
    count = len(np.asarray(left).reshape(-1, 2))
    return per_vertex(calibration.sigma0_px if pointing_sigma_px is None else pointing_sigma_px, count)


def _intersect_and_derivatives(calibration, left, right, station, frame, include_calibration,
                               pointing_sigma_px=None):
    pointing = _pointing(calibration, left, pointing_sigma_px)
    traced, result = _traced(calibration, left, right, station, frame, pointing)
    covariance = _usable_covariance(calibration, result, include_calibration)
    if covariance is None:
        return result, None, None
    names, sigma = covariance
    label = _station_label(calibration, station)
    _require_pose_covariance(calibration, label, frame, names)
    keys = [(id(calibration), label, frame, one.tobytes(), other.tobytes(), weight.tobytes())
            for one, other, weight in zip(traced[0].pixels, traced[1].pixels, pointing, strict=True)
            ] if len(left) <= FEW_ROWS else []
    with _KEEPING:
        kept = [_KEPT_ROWS.get(key) for key in keys]
    if keys and all(k is not None and k[0]() is calibration for k in kept):
        return result, np.stack([k[1] for k in kept], axis=1), sigma
    columns = stepped_cameras(calibration, station, frame)
    derivatives = _batched_derivatives(traced, result, columns, len(names), pointing)
    if len(keys) <= FEW_ROWS:
        with _KEEPING:
            for i, key in enumerate(keys):
                _KEPT_ROWS.pop(key, None)
                _KEPT_ROWS[key] = (weakref.ref(calibration), derivatives[:, i].copy())
            while len(_KEPT_ROWS) > KEPT_ROWS:
                del _KEPT_ROWS[next(iter(_KEPT_ROWS))]
    return result, derivatives, sigma


def _traced(calibration, left, right, station, frame, pointing: np.ndarray | float | None = None
            ) -> tuple[list[TracedRays], Intersection]:
    if frame not in ("object", "rig"):
        raise InvalidParameterError("frame", f"must be 'object' or 'rig', got {frame!r}")
    rig = calibration.rig(station, frame=frame)
    traced = [trace(camera, pixels, f"pixels of camera {i}")
              for i, (camera, pixels) in enumerate(zip(rig.cameras, (left, right), strict=True))]
    return traced, intersect_traced(traced, calibration.sigma0_px if pointing is None else pointing)


def _require_pose_covariance(calibration: StereoCalibration, label: str, frame: str, names) -> None:
    """Refuse a point in the object frame of a further station whose estimated pose the calibration's
    covariance leaves out (a calibration from many views keeps the covariance of the rig's unknowns only:
    the views' poses are eliminated as nuisance unknowns), rather than give a sigma without that pose's
    part. The rig frame needs no station pose."""
    if frame != "object" or label == calibration.stations[0]:
        return
    pose = [n for n in (f"{p}_l@{label}" for p in EXTERIOR_PARAMETERS)
            if n in calibration.parameters and calibration.parameters[n].sigma]
    if any(n not in names for n in pose):
        raise InvalidParameterError(
            "frame", f"the calibration keeps the covariance of the rig's unknowns only, not of the pose of station "
            f"{label!r} (one of {len(calibration.stations)} views eliminated as nuisance unknowns): a point in that "
            "station's object frame would miss its part of the sigma; measure in the rig frame")


def _usable_covariance(calibration, result, include_calibration) -> tuple[tuple[str, ...], np.ndarray] | None:
    """The calibration's (names, covariance) when its part is wanted and every name is a parameter."""
    if not include_calibration or calibration.covariance is None or not result.ok.any():
        return None
    names, sigma = calibration.covariance
    if not all(name in calibration.parameters for name in names):
        return None
    return tuple(names), np.asarray(sigma)


def _cameras(calibration: StereoCalibration, station: int | str, frame: str, values: dict[str, float]):
    """The two cameras the parameter ``values`` build at ``station`` in ``frame``, or None where they leave
    the valid region."""
    size = (calibration.left.width, calibration.left.height)
    try:
        return stereo_cameras(calibration.left.housing.kind, values, calibration.stations,
                              _station_label(calibration, station), size, frame)
    except UsvipsError:
        return None


def _stepped(calibration: StereoCalibration, station: int | str, frame: str):
    """(index, step, cameras or None) for every parameter of the covariance that can move a camera; None
    where the step leaves the valid region (its column stays zero)."""
    values = {name: p.value for name, p in calibration.parameters.items()}
    for j, name in enumerate(calibration.covariance[0]):
        if "@" in name and symbol(name) in ("X", "Y", "Z"):
            continue  # a control (or demoted tie) point's coordinate moves no camera: its column is zero
        step = _STEPS.get(symbol(name), 1e-6)
        moved = dict(values)
        moved[name] += step
        yield j, step, _cameras(calibration, station, frame, moved)


_KEPT: dict[tuple[int, str, str], tuple[weakref.ref, tuple[SteppedColumn, ...]]] = {}
_KEPT_ROWS: dict[tuple, tuple[weakref.ref, np.ndarray]] = {}
_KEEPING = threading.Lock()  # the window picks on its thread while a worker computes stored figures


def stepped_cameras(calibration: StereoCalibration, station: int | str = 0, frame: str = "object"
                    ) -> tuple[SteppedColumn, ...]:
    """The cameras of ``calibration`` at ``station`` in ``frame`` with each free parameter of its covariance
    stepped, for the parameters whose step moves a camera. They do not depend on the picks, so they are
    built once and kept for the last :data:`KEPT` calibrations (a calibration is immutable). Empty without
    a parameter covariance."""
    label = _station_label(calibration, station)
    if calibration.covariance is None:
        return ()
    key = (id(calibration), label, frame)
    with _KEEPING:
        kept = _KEPT.get(key)
    if kept is not None and kept[0]() is calibration:
        return kept[1]
    base = calibration.rig(label, frame=frame).cameras
    # the cameras the parameter values build unstepped: a step that leaves a camera as these has not moved
    # it (the calibration's own cameras may differ from them by rounding: the relative orientation)
    values = {name: p.value for name, p in calibration.parameters.items()}
    unstepped = _cameras(calibration, label, frame, values) or (None, None)
    columns = []
    for j, step, cameras in _stepped(calibration, label, frame):
        if cameras is None:
            continue
        moved = tuple(_how_moved(*one) for one in zip(base, unstepped, cameras, strict=True))
        if moved != (UNMOVED, UNMOVED):
            columns.append(SteppedColumn(j, step, cameras, moved))
    columns = tuple(columns)
    with _KEEPING:
        while len(_KEPT) >= KEPT:
            del _KEPT[next(iter(_KEPT))]
        _KEPT[key] = (weakref.ref(calibration), columns)
    return columns


def _how_moved(base: Camera, unstepped: Camera | None, stepped: Camera) -> int:
    """How a step moved a camera from ``base`` (the calibration's, which the picks are traced with)."""
    if _equal(stepped, base) or (unstepped is not None and _equal(stepped, unstepped)):
        return UNMOVED
    affine = {name: getattr(base.interior, name) for name in AFFINE}
    if (_equal(stepped.housing, base.housing) and replace(stepped.interior, **affine) == base.interior
            and (stepped.width, stepped.height) == (base.width, base.height)):
        return MAPPED
    return RETRACE


def _equal(one, other) -> bool:
    try:
        return one is other or bool(one == other)
    except (ValueError, TypeError):  # a housing holding arrays does not compare by value
        return False


def _moved_rigidly(traced: TracedRays, camera: Camera) -> TracedRays:
    """The rays of ``traced`` carried with their camera to ``camera``'s pose (same interior and housing):
    what a trace through ``camera`` gives, without tracing. Object vectors are rows: v = v_camera · M."""
    before, after = traced.camera.exterior, camera.exterior
    turn = before.rotation.T @ after.rotation
    rays = traced.rays
    origins = (rays.origins - before.position) @ turn + after.position
    bundle = RayBundle(origins, rays.directions @ turn, rays.status, rays.failed_surface)
    d_origins = np.einsum("nic,ij->njc", traced.d_origins, turn)
    d_directions = np.einsum("nic,ij->njc", traced.d_directions, turn)
    return TracedRays(camera, traced.pixels, bundle, d_origins, d_directions)


def _pixel_map(base: Interior, stepped: Interior, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pixels (N, 2) at which ``base`` reads the distorted normalised coordinates ``stepped`` reads at
    ``pixels`` (the two differ in :data:`AFFINE` only), and the map's constant Jacobian ∂q/∂p (2, 2)."""

    def mapped(p: np.ndarray) -> np.ndarray:
        return base.image_to_pixels(stepped.pixels_to_image(p) * (base.f / stepped.f))

    corners = mapped(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]))
    return mapped(pixels), (corners[1:] - corners[0]).T


def _split(traced: TracedRays, count: int) -> list[TracedRays]:
    """``traced`` of ``count`` equal blocks of rows, one TracedRays each."""
    n = len(traced.rays) // max(count, 1)
    rays = traced.rays
    return [TracedRays(traced.camera, traced.pixels[k * n:(k + 1) * n],
                       RayBundle(rays.origins[k * n:(k + 1) * n], rays.directions[k * n:(k + 1) * n],
                                 rays.status[k * n:(k + 1) * n], rays.failed_surface[k * n:(k + 1) * n]),
                       traced.d_origins[k * n:(k + 1) * n], traced.d_directions[k * n:(k + 1) * n])
            for k in range(count)]


def _mapped(base: TracedRays, columns: tuple[SteppedColumn, ...], side: int) -> dict[int, TracedRays]:
    """The rays of the ``MAPPED`` columns of ``side`` (by position in ``columns``): the pixels of every
    column whose affine map moved traced at once through the calibration's camera, their pixel derivatives
    carried through the map (∂ray/∂p = ∂ray/∂q · ∂q/∂p), then moved rigidly to the stepped pose."""
    camera = base.camera
    moved = [k for k, c in enumerate(columns) if c.moved[side] == MAPPED]
    remapped = [k for k in moved if columns[k].cameras[side].interior != camera.interior]
    out = {k: base for k in moved if k not in remapped}
    if remapped:
        maps = [_pixel_map(camera.interior, columns[k].cameras[side].interior, base.pixels) for k in remapped]
        traced = trace(camera, np.concatenate([q for q, _ in maps]))
        for k, (_, jacobian), part in zip(remapped, maps, _split(traced, len(remapped)), strict=True):
            out[k] = TracedRays(camera, base.pixels, part.rays, part.d_origins @ jacobian,
                                part.d_directions @ jacobian)
    for k in moved:
        stepped = columns[k].cameras[side]
        if stepped.exterior != camera.exterior:
            out[k] = _moved_rigidly(out[k], stepped)
    return out


def _stacked(parts: list[TracedRays]) -> TracedRays:
    rays = [p.rays for p in parts]
    bundle = RayBundle(np.concatenate([r.origins for r in rays]), np.concatenate([r.directions for r in rays]),
                       np.concatenate([r.status for r in rays]), np.concatenate([r.failed_surface for r in rays]))
    return TracedRays(parts[0].camera, np.concatenate([p.pixels for p in parts]), bundle,
                      np.concatenate([p.d_origins for p in parts]), np.concatenate([p.d_directions for p in parts]))


def _batched_derivatives(traced: list[TracedRays], result: Intersection, columns: tuple[SteppedColumn, ...],
                         count: int, pointing: np.ndarray) -> np.ndarray:
    """∂point/∂parameter (count, N, 3), metres per parameter unit: forward differences of the intersection
    over ``columns``, the stepped rays of a batch of columns intersected in one call. When a batch holds
    several columns its first rows are the unstepped rays, so that both sides of a difference come from the
    same intersection kernel (which depends on the rows of a call); a batch of one column (many points) has
    as many rows as ``result`` and is differenced against it."""
    n = len(result.points)
    derivatives = np.zeros((count, n, 3))
    per_batch = max(1, BATCH_ROWS // max(n, 1) - 1)
    with_base = per_batch > 1
    for start in range(0, len(columns), per_batch):
        batch = columns[start:start + per_batch]
        sides = []
        for side, base in enumerate(traced):
            mapped = _mapped(base, batch, side)
            parts = [base] if with_base else []
            for k, column in enumerate(batch):
                how = column.moved[side]
                parts.append(base if how == UNMOVED else mapped[k] if how == MAPPED
                             else trace(column.cameras[side], base.pixels))
            sides.append(_stacked(parts) if len(parts) > 1 else parts[0])
        rows = len(batch) + with_base
        again = intersect_traced(sides, pointing[:1] if pointing.strides[0] == 0 else np.tile(pointing, (rows, 1)))
        points = again.points.reshape(rows, n, 3)
        ok = again.ok.reshape(rows, n) & result.ok
        reference = points[0] if with_base else result.points
        if with_base:
            ok &= ok[0]
        for k, column in enumerate(batch, start=int(with_base)):
            usable = ok[k]
            derivatives[column.index, usable] = (points[k, usable] - reference[usable]) / column.step
    return derivatives


def reference_derivatives(calibration: StereoCalibration, left: np.ndarray, right: np.ndarray,
                          station: int | str = 0, frame: str = "object",
                          pointing_sigma_px: float | np.ndarray | None = None) -> np.ndarray | None:
    """The plain path the batched derivatives are tested against: per parameter, the cameras rebuilt
    with it stepped, the pixels retraced, the point re-intersected. (count, N, 3) or None when the
    calibration has no usable covariance."""
    pointing = _pointing(calibration, left, pointing_sigma_px)
    traced, result = _traced(calibration, left, right, station, frame, pointing)
    covariance = _usable_covariance(calibration, result, True)
    if covariance is None:
        return None
    derivatives = np.zeros((len(covariance[0]),) + result.points.shape)
    for j, step, cameras in _stepped(calibration, station, frame):
        if cameras is None:
            continue
        # (a camera the step did not change keeps its traced rays)
        again = intersect_traced([retrace(one, camera) for one, camera in zip(traced, cameras, strict=True)],
                                 pointing)
        usable = result.ok & again.ok
        derivatives[j, usable] = (again.points[usable] - result.points[usable]) / step
    return derivatives
