"""Intersection with the calibration's own uncertainty propagated into every point.

The pixel part of a point's covariance comes from the pointing precision of its pixels (``pointing_sigma_px``,
px per image coordinate, :mod:`usvips.core.pointing`; ``intersection.py``). A
calibration estimated from few control points is itself uncertain, and that error is common to every
point measured with it: its part is J Σ Jᵀ, with Σ the calibration's a-posteriori covariance of its free
parameters and J = ∂point/∂parameter.

J is computed for all points at once (:mod:`usvips.core.calibration.point_derivatives`): the
implicit-function theorem on the weighted least-squares intersection turns each parameter's motion of the
traced rays into the point's motion, poses and interior parameters in closed form from the rays traced once
with their pixel derivatives, housing parameters by the pixels traced through the housing built at θ ± h.
How each parameter moves each camera does not depend on the picks: it is found once per (calibration,
station, frame) from the cameras the calibration's values build at θ ± h, and kept
(:func:`stepped_cameras`). The derivatives of a few rows (a pick's vertex) are kept: the figures of the
object stored from those picks then need no derivative computed again (each row's derivatives depend on
that row's pixels alone). :func:`reference_derivatives` is the plain loop (rebuild, retrace,
re-intersect per parameter) the derivatives are tested against.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from usvips.core.calibration.model import _STEPS, stereo_cameras
from usvips.core.calibration.parameter_names import symbol
from usvips.core.calibration.point_derivatives import CameraMotion, camera_motion, housing_rays, point_jacobian
from usvips.core.camera import EXTERIOR_PARAMETERS
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.intersection import Intersection, TracedRays, intersect_traced, pixel_jacobian, retrace, trace
from usvips.core.pointing import per_vertex
from usvips.core.rays import RayBundle
from usvips.core.stereo_calibration import StereoCalibration

#: points whose derivatives are computed in one block: bounds the memory of a large batch
BATCH_ROWS = 16_384
#: calibrations (with their station and frame) whose stepped cameras are kept
KEPT = 8
#: rows (one vertex's pixels) whose derivatives are kept, from calls of at most :data:`FEW_ROWS` rows
KEPT_ROWS = 64
FEW_ROWS = 16

@dataclass(frozen=True)
class SteppedColumn:
    """One free parameter of the calibration's covariance: its row ``index`` in the covariance, the
    ``step`` h (parameter units) of the cameras built at θ ± h, and how it moves each of the two cameras
    (None: not at all)."""

    index: int
    step: float
    motions: tuple[CameraMotion | None, CameraMotion | None]


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
    if len(np.asarray(left).reshape(-1, 2)) > FEW_ROWS:  # many points: J Σ Jᵀ block by block
        pointing, traced, result, covariance = _prepared(calibration, left, right, station, frame,
                                                         include_calibration, pointing_sigma_px)
        if covariance is None:
            return result
        columns = stepped_cameras(calibration, station, frame)
        calibration_part = _calibration_part(traced, result, columns, covariance[1], pointing)
    else:
        result, derivatives, sigma = _intersect_and_derivatives(calibration, left, right, station, frame,
                                                                include_calibration, pointing_sigma_px)
        if derivatives is None:
            return result
        calibration_part = _sandwich(np.ascontiguousarray(derivatives.transpose(1, 2, 0)), sigma)
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


def _prepared(calibration, left, right, station, frame, include_calibration, pointing_sigma_px):
    """(pointing sigmas (N, 2), traced rays, intersection, (names, Σ) or None without a usable
    covariance); refuses a station pose the covariance leaves out."""
    pointing = _pointing(calibration, left, pointing_sigma_px)
    traced, result = _traced(calibration, left, right, station, frame, pointing)
    covariance = _usable_covariance(calibration, result, include_calibration)
    if covariance is not None:
        _require_pose_covariance(calibration, _station_label(calibration, station), frame, covariance[0])
    return pointing, traced, result, covariance


def _intersect_and_derivatives(calibration, left, right, station, frame, include_calibration,
                               pointing_sigma_px=None):
    pointing, traced, result, covariance = _prepared(calibration, left, right, station, frame,
                                                     include_calibration, pointing_sigma_px)
    if covariance is None:
        return result, None, None
    names, sigma = covariance
    label = _station_label(calibration, station)
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


def _stepped(calibration: StereoCalibration, station: int | str, frame: str, signs: tuple[int, ...] = (1,)):
    """(index, step, {sign: cameras or None}) for every parameter of the covariance that can move a camera,
    with the cameras built at θ + sign·step for each of ``signs``; None where a step leaves the valid
    region."""
    values = {name: p.value for name, p in calibration.parameters.items()}
    for j, name in enumerate(calibration.covariance[0]):
        if "@" in name and symbol(name) in ("X", "Y", "Z"):
            continue  # a control (or demoted tie) point's coordinate moves no camera: its column is zero
        step = _STEPS.get(symbol(name), 1e-6)
        built = {}
        for sign in signs:
            moved = dict(values)
            moved[name] += sign * step
            built[sign] = _cameras(calibration, station, frame, moved)
        yield j, step, built


_KEPT: dict[tuple[int, str, str], tuple[weakref.ref, tuple[SteppedColumn, ...]]] = {}
_KEPT_ROWS: dict[tuple, tuple[weakref.ref, np.ndarray]] = {}
_KEEPING = threading.Lock()  # the window picks on its thread while a worker computes stored figures


def stepped_cameras(calibration: StereoCalibration, station: int | str = 0, frame: str = "object"
                    ) -> tuple[SteppedColumn, ...]:
    """How each free parameter of the covariance of ``calibration`` moves its two cameras at ``station`` in
    ``frame`` (from the cameras built at θ ± h; one-sided, from the unstepped values, where one of them
    leaves the valid region), for the parameters that move a camera. It does not depend on the picks, so
    it is found once and kept for the last :data:`KEPT` calibrations (a calibration is immutable). Empty
    without a parameter covariance."""
    label = _station_label(calibration, station)
    if calibration.covariance is None:
        return ()
    key = (id(calibration), label, frame)
    with _KEEPING:
        kept = _KEPT.get(key)
    if kept is not None and kept[0]() is calibration:
        return kept[1]
    base = calibration.rig(label, frame=frame).cameras
    values = {name: p.value for name, p in calibration.parameters.items()}
    unstepped = _cameras(calibration, label, frame, values)
    columns = []
    for j, step, built in _stepped(calibration, label, frame, (-1, 1)):
        minus, plus, span = built[-1], built[1], 2 * step
        if minus is None or plus is None:
            minus, plus, span = minus or unstepped, plus or unstepped, step
            if minus is None or plus is None or minus is plus:
                continue  # no step stays valid: the column stays zero
        motions = tuple(camera_motion(*one, span) for one in zip(base, minus, plus, strict=True))
        motions = tuple(m if m.moves else None for m in motions)
        if any(m is not None for m in motions):
            columns.append(SteppedColumn(j, step, motions))
    # the left camera's columns, then those of both, then the right's: each camera's a contiguous range
    columns = tuple(sorted(columns, key=_camera_order))
    with _KEEPING:
        while len(_KEPT) >= KEPT:
            del _KEPT[next(iter(_KEPT))]
        _KEPT[key] = (weakref.ref(calibration), columns)
    return columns


def _camera_order(column: SteppedColumn) -> int:
    """0 for a column that moves the left camera only, 1 for both, 2 for the right only."""
    left, right = column.motions
    return 0 if right is None else (2 if left is None else 1)


def _rows(traced: TracedRays, rows: slice | np.ndarray) -> TracedRays:
    """The ``rows`` of ``traced``."""
    rays = traced.rays
    return TracedRays(traced.camera, traced.pixels[rows],
                      RayBundle(rays.origins[rows], rays.directions[rows], rays.status[rows],
                                rays.failed_surface[rows]),
                      traced.d_origins[rows], traced.d_directions[rows])


def _derivative_blocks(traced: list[TracedRays], result: Intersection, columns: tuple[SteppedColumn, ...],
                       pointing: np.ndarray) -> Iterator[tuple[slice | np.ndarray, np.ndarray]]:
    """(rows, ∂point/∂parameter (n, 3, len(columns))) of the intersected points, :data:`BATCH_ROWS` at a
    time, the parameters in the order of ``columns`` (those that move a camera); metres per parameter unit
    (:func:`~usvips.core.calibration.point_derivatives.point_jacobian`)."""
    n = len(result.points)
    motions = [[(k, c.motions[side]) for k, c in enumerate(columns) if c.motions[side] is not None]
               for side in range(len(traced))]
    weights = 1.0 / np.broadcast_to(pointing, (n, len(traced))) ** 2
    every = bool(result.ok.all())
    chosen = np.arange(n) if every else np.flatnonzero(result.ok)
    for start in range(0, len(chosen), BATCH_ROWS):
        rows = slice(start, min(start + BATCH_ROWS, n)) if every else chosen[start:start + BATCH_ROWS]
        block = [_rows(t, rows) for t in traced]
        # the block's rays through the moved housings (traced per block: bounded memory for any N)
        ideal = [_ideal(t, motions[j]) for j, t in enumerate(block)]
        housings = [housing_rays(t, [m for _, m in motions[j]], ideal[j]) for j, t in enumerate(block)]
        yield rows, point_jacobian(block, result.points[rows], result.covariance[rows], weights[rows], motions,
                                   len(columns), housings, ideal)


def _ideal(traced: TracedRays, motions: list[tuple[int, CameraMotion]]) -> np.ndarray | None:
    """The ideal normalised coordinates of the pixels of ``traced`` when a motion moves its housing or its
    lens's distortion (else None)."""
    if any(m.housings is not None or (m.interiors is not None and _distortion_moves(m.interiors))
           for _, m in motions):
        return traced.camera.interior.pixels_to_normalised(traced.pixels)
    return None


def _distortion_moves(interiors: tuple) -> bool:
    """Whether the two interiors differ in their distortion."""
    minus, plus = interiors
    return any(getattr(minus, name) != getattr(plus, name) for name in ("k1", "k2", "k3", "p1", "p2"))


def _batched_derivatives(traced: list[TracedRays], result: Intersection, columns: tuple[SteppedColumn, ...],
                         count: int, pointing: np.ndarray) -> np.ndarray:
    """∂point/∂parameter (count, N, 3), metres per parameter unit, of every intersected point (zero rows
    for points that did not intersect, zero columns for parameters that move no camera)."""
    jacobian = np.zeros((len(result.points), 3, count))
    index = [c.index for c in columns]
    for rows, block in _derivative_blocks(traced, result, columns, pointing):
        jacobian[np.ix_(np.arange(len(jacobian))[rows], range(3), index)] = block
    return jacobian.transpose(2, 0, 1)


def _calibration_part(traced: list[TracedRays], result: Intersection, columns: tuple[SteppedColumn, ...],
                      sigma: np.ndarray, pointing: np.ndarray) -> np.ndarray:
    """J Σ Jᵀ (N, 3, 3) of every point (zero for points that did not intersect), block by block without
    the whole J."""
    part = np.zeros((len(result.points), 3, 3))
    index = [c.index for c in columns]
    moved = np.ascontiguousarray(sigma[np.ix_(index, index)])
    for rows, block in _derivative_blocks(traced, result, columns, pointing):
        part[rows] = _sandwich(block, moved)
    return part


def _sandwich(jacobian: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """J Σ Jᵀ (N, 3, 3) of J (N, 3, P) and Σ (P, P)."""
    n, count = len(jacobian), len(sigma)
    product = (jacobian.reshape(3 * n, count) @ sigma).reshape(n, 3, count)
    return np.matmul(product, jacobian.transpose(0, 2, 1))


def reference_derivatives(calibration: StereoCalibration, left: np.ndarray, right: np.ndarray,
                          station: int | str = 0, frame: str = "object",
                          pointing_sigma_px: float | np.ndarray | None = None) -> np.ndarray | None:
    """The plain path the derivatives are tested against: per parameter, the cameras rebuilt at θ ± h,
    the pixels retraced through them, each ray's point at the intersected point's depth differenced, and
    the point moved as the weighted intersection moves with its rays to first order,
    ∂X = C Σ_j A_jᵀ A_j ∂Q_j / σ_j² (see :mod:`usvips.core.calibration.point_derivatives`).
    (count, N, 3) or None when the calibration has no usable covariance."""
    pointing = _pointing(calibration, left, pointing_sigma_px)
    traced, result = _traced(calibration, left, right, station, frame, pointing)
    covariance = _usable_covariance(calibration, result, True)
    if covariance is None:
        return None
    weights = 1.0 / np.broadcast_to(pointing, (len(result.points), len(traced))) ** 2
    depths, gains = [], []
    for j, one in enumerate(traced):
        along = np.einsum("ni,ni->n", result.points - one.rays.origins, one.rays.directions)
        a0, a1, _ = pixel_jacobian(one.rays.directions, one.d_origins, one.d_directions, along)
        rows = np.stack([a0, a1], axis=1)
        depths.append(along)
        gains.append(np.einsum("nij,nkj,nkl->nil", result.covariance, rows, rows) * weights[:, j, None, None])
    derivatives = np.zeros((len(covariance[0]),) + result.points.shape)
    for j, step, built in _stepped(calibration, station, frame, (-1, 1)):
        if built[-1] is None or built[1] is None:
            continue
        usable = result.ok.copy()
        for side, one in enumerate(traced):
            # (a camera the step did not change keeps its traced rays)
            minus, plus = (retrace(one, cameras[side]).rays for cameras in (built[-1], built[1]))
            moved = (plus.origins - minus.origins + depths[side][:, None] * (plus.directions - minus.directions))
            derivatives[j] += np.einsum("nij,nj->ni", gains[side], moved) / (2 * step)
            usable &= plus.ok & minus.ok
        derivatives[j, ~usable] = 0.0
    return derivatives
