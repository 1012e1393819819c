"""The precision planner: the expected sigma of a point and of a length over the field of view and range.

Given a calibration, or a planned rig (:func:`planned_rig`: cameras, baseline, toe-in, housing), the map
covers a vertical plane of the rig's common view: positions ``across`` (metres, along the baseline,
0 = the middle of the baseline) at distances ``ranges`` (metres from the middle of the baseline along
the rig's view direction, the mean of the two optical axes), at ``height`` above the baseline (metres,
up in the left camera's image). Everything is computed in the rig frame (the left perspective centre at
the origin, the left camera's axes: x right, y up, z backwards; metres).

At every position the point is projected into both cameras, and its conjugate pixels are intersected
with :func:`usvips.core.calibration.uncertainty.joint_covariance`: the pointing precision (sigma0, pixels)
and, where the calibration carries a covariance, the calibration's own uncertainty, which is common to
every point and so correlates the two ends of a length. A length ``length`` (metres, e.g. a 0.3 m fish)
centred there is placed along ``orientations`` directions spread evenly over the sphere; its sigma is
:func:`usvips.core.measure.distance` of its two intersected ends (the function every measurement uses).
The map gives the RMS and the largest of those sigmas over the orientations whose two ends are seen.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from usvips.core import housing as housings
from usvips.core.calibration.uncertainty import joint_covariance
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.housing import AirHousing, Housing
from usvips.core.interior import Interior
from usvips.core.intersection import intersect
from usvips.core.measure import distance
from usvips.core.rotation import angles_from_matrix
from usvips.core.stereo_calibration import StereoCalibration


@dataclass(frozen=True)
class RigAxes:
    """The rig's viewing geometry in the rig frame (metres): ``middle`` of the baseline, unit ``view``
    direction (mean optical axis), unit ``across`` (the baseline made perpendicular to view) and ``up``."""

    middle: np.ndarray
    view: np.ndarray
    across: np.ndarray
    up: np.ndarray

    def positions(self, across: np.ndarray, ranges: np.ndarray, height: float = 0.0) -> np.ndarray:
        """Grid positions (len(ranges), len(across), 3), metres, rig frame."""
        a, r = np.meshgrid(np.asarray(across, float), np.asarray(ranges, float))
        return (self.middle + r[..., None] * self.view + a[..., None] * self.across + height * self.up)


@dataclass(frozen=True)
class PrecisionMap:
    """The planner's answer. across (nx,), ranges (nz,) metres; visible (nz, nx): the point is seen by
    both cameras; point_sigma (nz, nx, 3): sigma of the point along across, up and view (metres);
    length_rms, length_worst (nz, nx): the length's sigma (metres), RMS and largest over the orientations
    seen (NaN where none is); orientations_seen (nz, nx): how many were; length (m), sigma_px (pointing
    precision used), with_calibration (the calibration's own uncertainty included)."""

    across: np.ndarray
    ranges: np.ndarray
    height: float
    visible: np.ndarray
    point_sigma: np.ndarray
    length_rms: np.ndarray
    length_worst: np.ndarray
    orientations_seen: np.ndarray
    length: float
    sigma_px: float
    with_calibration: bool

    def summary(self) -> dict:
        """Plain numbers for JSON: per range, the best and worst figures over the positions seen."""
        rows = []
        for k, r in enumerate(self.ranges):
            seen = self.visible[k]
            total = np.sqrt(np.sum(self.point_sigma[k] ** 2, axis=-1))
            lengths = self.length_rms[k][np.isfinite(self.length_rms[k])]
            rows.append({"range_m": float(r), "positions_seen": int(seen.sum()),
                         "across_seen_m": [float(self.across[seen].min()), float(self.across[seen].max())]
                         if seen.any() else None,
                         "point_sigma_m": [float(np.nanmin(total[seen])), float(np.nanmax(total[seen]))]
                         if seen.any() else None,
                         "length_sigma_rms_m": [float(lengths.min()), float(lengths.max())] if lengths.size else None,
                         "length_sigma_worst_m": float(np.nanmax(self.length_worst[k]))
                         if np.isfinite(self.length_worst[k]).any() else None})
        return {"length_m": self.length, "sigma_px": self.sigma_px, "with_calibration": self.with_calibration,
                "height_m": self.height, "ranges": rows}


def rig_axes(calibration: StereoCalibration) -> RigAxes:
    """The rig's middle, view direction, across and up axes in the rig frame."""
    rig = calibration.rig(frame="rig")
    left, right = rig.left.exterior, rig.right.exterior
    axes = [e.rotation.T @ np.array([0.0, 0.0, -1.0]) for e in (left, right)]  # optical axes, object frame
    view = axes[0] + axes[1]
    view /= np.linalg.norm(view)
    base = right.position - left.position
    across = base - view * (base @ view)
    if np.linalg.norm(across) < 1e-9:
        raise DegenerateGeometryError("the baseline lies along the view direction: no across axis for a map")
    across /= np.linalg.norm(across)
    return RigAxes((left.position + right.position) / 2, view, across, np.cross(across, view))


def sphere_directions(count: int) -> np.ndarray:
    """``count`` unit vectors spread evenly over a half sphere (a length's direction has no sign), (count, 3)."""
    if count < 1:
        raise InvalidParameterError("orientations", f"must be at least 1, got {count}")
    k = np.arange(count) + 0.5
    z = k / count                       # uniform in [0, 1]: the upper half sphere, equal areas
    phi = k * np.pi * (3.0 - np.sqrt(5.0))  # golden angle
    s = np.sqrt(1.0 - z * z)
    return np.column_stack([s * np.cos(phi), s * np.sin(phi), z])


def planned_rig(f_px: float, width: int, height: int, baseline_m: float, toe_in_rad: float = 0.0,
                housing: Housing | None = None, sigma_px: float = 0.3) -> StereoCalibration:
    """A rig on paper: two equal pinhole cameras (principal distance f_px pixels, principal point at the
    frame centre, image width × height pixels), ``baseline_m`` apart, each turned inward by
    ``toe_in_rad`` about its vertical axis, behind ``housing`` (in each camera's frame; default in air),
    measured with pointing precision ``sigma_px``. No calibration uncertainty."""
    if not np.isfinite(baseline_m) or baseline_m <= 0:
        raise InvalidParameterError("baseline", f"must be > 0 metres, got {baseline_m}")
    if not np.isfinite(toe_in_rad) or abs(toe_in_rad) >= np.pi / 4:
        raise InvalidParameterError("toe-in", f"must be within ±45°, got {np.degrees(toe_in_rad):g}°")
    if int(width) <= 0 or int(height) <= 0:
        raise InvalidParameterError("image size", f"must be > 0 pixels, got {width} × {height}")
    interior = Interior(f=f_px, xp=(width - 1) / 2, yp=(height - 1) / 2)
    housing = housing or AirHousing()
    cameras = []
    for sign in (1.0, -1.0):  # left turned toward +x, right toward −x
        angle = sign * toe_in_rad
        c, s = np.cos(angle), np.sin(angle)
        # M (object → image) whose optical axis Mᵀ·(0, 0, −1) = (sin τ, 0, −cos τ): turned toward the middle
        m = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
        exterior = Exterior(-sign * baseline_m / 2, 0.0, 0.0, *angles_from_matrix(m))
        cameras.append(Camera(interior, exterior, housing, int(width), int(height)))
    phase = "water" if housing.kind in housings.water_names() else "air"
    return StereoCalibration.from_cameras(cameras[0], cameras[1], phase, sigma_px, station="plan",
                                          source={"planned": True})


def precision_map(calibration: StereoCalibration, across: np.ndarray, ranges: np.ndarray, length: float = 0.3,
                  height: float = 0.0, orientations: int = 12, include_calibration: bool = True,
                  on_row: Callable[[int, int], None] | None = None) -> PrecisionMap:
    """The expected sigma of a point and of a ``length`` (metres) over the grid (module docstring).

    ``on_row(done, total)`` is called after each range (for progress; it may raise to stop the work).

    Raises :class:`DegenerateGeometryError` naming the first range at which no position is seen by both
    cameras (with the ranges that are), and :class:`InvalidParameterError` for a bad grid or length."""
    across = np.asarray(across, dtype=np.float64).ravel()
    ranges = np.asarray(ranges, dtype=np.float64).ravel()
    if across.size < 1 or ranges.size < 1 or not (np.all(np.isfinite(across)) and np.all(np.isfinite(ranges))):
        raise InvalidParameterError("grid", "across and ranges must be finite numbers (metres)")
    if np.any(ranges <= 0):
        raise InvalidParameterError("range", f"must be > 0 metres, got {ranges[ranges <= 0][0]:g}")
    if not np.isfinite(length) or length <= 0:
        raise InvalidParameterError("length", f"must be > 0 metres, got {length}")
    if calibration.left.width is None or calibration.right.width is None:
        raise InvalidParameterError("image size", "the calibration records no image size: the field of view is "
                                    "unknown (give the image size)")
    rig = calibration.rig(frame="rig")
    axes = rig_axes(calibration)
    grid = axes.positions(across, ranges, height)
    directions = sphere_directions(orientations)
    directions = (directions[:, :1] * axes.across + directions[:, 1:2] * axes.up + directions[:, 2:] * axes.view)
    nz, nx = grid.shape[:2]
    point_sigma = np.full((nz, nx, 3), np.nan)
    length_rms = np.full((nz, nx), np.nan)
    length_worst = np.full((nz, nx), np.nan)
    seen_count = np.zeros((nz, nx), dtype=int)
    visible = np.zeros((nz, nx), dtype=bool)
    frame_axes = np.vstack([axes.across, axes.up, axes.view])
    with_calibration = include_calibration and calibration.covariance is not None
    for k in range(nz):
        centres = grid[k]
        ends = centres[:, None, None, :] + np.array([-0.5, 0.5])[None, None, :, None] * length \
            * directions[None, :, None, :]  # (nx, K, 2, 3)
        points = np.concatenate([centres[:, None, :], ends.reshape(nx, -1, 3)], axis=1).reshape(-1, 3)
        left, right = rig.left.project(points), rig.right.project(points)
        ok = (left.status == 0) & (right.status == 0)
        if not ok.reshape(nx, -1)[:, 0].any():
            seen = [float(r) for r in ranges if _seen_at(rig, axes, across, r, height)]
            where = (f"positions are seen from {min(seen):g} m to {max(seen):g} m" if seen else
                     "no requested range is")
            raise DegenerateGeometryError(
                f"range {ranges[k]:g} m: no position across {across.min():g}..{across.max():g} m is seen by both "
                f"cameras ({where})")
        index = np.flatnonzero(ok)
        if with_calibration:
            result, covariance = joint_covariance(calibration, left.pixels[index], right.pixels[index], frame="rig")
        else:
            result, covariance = _pointing_only(calibration, left.pixels[index], right.pixels[index])
        good = np.zeros(points.shape[0], dtype=bool)
        good[index] = result.ok
        position = -np.ones(points.shape[0], dtype=int)
        position[index] = np.arange(index.size)
        per_cell = 1 + 2 * len(directions)
        for i in range(nx):
            base = i * per_cell
            if not good[base]:
                continue
            visible[k, i] = True
            j = position[base]
            point_sigma[k, i] = np.sqrt(np.clip(np.diag(frame_axes @ covariance[3 * j:3 * j + 3, 3 * j:3 * j + 3]
                                                        @ frame_axes.T), 0.0, None))
            sigmas = []
            for d in range(len(directions)):
                a, b = base + 1 + 2 * d, base + 2 + 2 * d
                if not (good[a] and good[b]):
                    continue
                rows = np.r_[3 * position[a]:3 * position[a] + 3, 3 * position[b]:3 * position[b] + 3]
                figure = distance(result.points[[position[a], position[b]]], covariance[np.ix_(rows, rows)])
                sigmas.append(figure.sigma)
            if sigmas:
                seen_count[k, i] = len(sigmas)
                length_rms[k, i] = float(np.sqrt(np.mean(np.square(sigmas))))
                length_worst[k, i] = float(np.max(sigmas))
        if on_row is not None:
            on_row(k + 1, nz)
    return PrecisionMap(across, ranges, float(height), visible, point_sigma, length_rms, length_worst, seen_count,
                        float(length), calibration.sigma0_px, with_calibration)


def _pointing_only(calibration: StereoCalibration, left: np.ndarray, right: np.ndarray):
    """The intersection and its (3N, 3N) covariance from the pointing precision alone (block diagonal)."""
    rig = calibration.rig(frame="rig")
    result = intersect(rig.cameras, [left, right], calibration.sigma0_px)
    n = len(result.points)
    full = np.zeros((3 * n, 3 * n))
    for i in range(n):
        full[3 * i:3 * i + 3, 3 * i:3 * i + 3] = result.covariance[i]
    return result, full


def _seen_at(rig, axes: RigAxes, across: np.ndarray, range_m: float, height: float) -> bool:
    points = axes.positions(across, np.array([range_m]), height).reshape(-1, 3)
    return bool(np.any((rig.left.project(points).status == 0) & (rig.right.project(points).status == 0)))


def default_grid(calibration: StereoCalibration, columns: int = 15, rows: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """A grid that covers the common view: ranges from the nearest distance at which the middle of the
    view is seen by both cameras (searched from 5 cm to 100 m) to 4 m beyond it, and across positions over
    the part of the farthest range that both cameras see (metres)."""
    rig = calibration.rig(frame="rig")
    axes = rig_axes(calibration)
    trial = np.geomspace(0.05, 100.0, 400)
    middle = axes.positions(np.zeros(1), trial).reshape(-1, 3)
    seen = (rig.left.project(middle).status == 0) & (rig.right.project(middle).status == 0)
    if not seen.any():
        raise DegenerateGeometryError("the two cameras see no common point straight ahead of the rig between "
                                      "0.05 m and 100 m (toe-in or baseline wrong?)")
    near = float(np.ceil(trial[np.argmax(seen)] * 10) / 10)
    far = near + 4.0
    half = max(c.width / 2 / c.interior.f for c in (rig.left, rig.right)) * far  # in air: wider than in water
    wide = np.linspace(-half, half, 401)
    points = axes.positions(wide, np.array([far])).reshape(-1, 3)
    inside = wide[(rig.left.project(points).status == 0) & (rig.right.project(points).status == 0)]
    return np.linspace(inside.min(), inside.max(), columns), np.linspace(near, far, rows)
