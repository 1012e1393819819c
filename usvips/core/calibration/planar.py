"""The calibration's start from a planar target (a printed board): no 3-D spread needed.

The DLT (:mod:`usvips.core.dlt`) needs control off one plane; the most common target in the world is a
flat board. For a planar target each view gives each camera a homography from the board's plane to the
image; Zhang's closed form over all views of a camera gives its interior (f, xp, yp with sy = 1 and no
distortion), and each view's pose follows (OpenCV's ``calibrateCamera`` with distortion fixed at zero
does both, refined jointly: an acceptable start, converted here to our conventions). The rig's relative
orientation is the median over the views of each view's left → right orientation, so one bad view does
not spoil the start. The joint adjustment (:mod:`.phases`) then frees distortion and sy.

Conventions: pixels x right, y down, origin at the centre of the top-left pixel (OpenCV's too). OpenCV's
camera frame is x right, y down, z forward; ours is x right, y up, looking along −z: camera-frame
vectors differ by :data:`FLIP` = diag(1, −1, −1). An OpenCV pose (R, t) maps object points into its
camera frame, x_cv = R·X + t; ours is M = FLIP·R (object → image, omega-phi-kappa) and the perspective
centre X0 = −Rᵀ·t (metres). The camera matrix gives f = fx, sy = fx / fy, (xp, yp) = (cx, cy).

Degenerate sets are refused by name (:class:`DegenerateGeometryError`): too few views, a view with too
few points, a point seen by one camera only, and views that are all (nearly) parallel to the image
plane, where the focal length and the distance cannot be told apart: measured, independently of the
focal length, by how much the board's depth varies across it in each view (the homography's third row
is proportional to each point's depth).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from usvips.core.camera import Exterior
from usvips.core.errors import DegenerateGeometryError
from usvips.core.interior import Interior
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.rig import RelativeOrientation, relative_orientation, right_exterior
from usvips.core.rotation import angles_from_matrix, rotation_matrix

#: OpenCV camera frame (x right, y down, z forward) ↔ ours (x right, y up, looking along −z).
FLIP = np.diag([1.0, -1.0, -1.0])

#: Control whose thickness / extent (smallest / largest singular value of the centred points) is below
#: this is (nearly) coplanar: the DLT refuses it (:func:`usvips.core.dlt.check_spread`), the planar start
#: takes it.
COPLANAR_RATIO = 1e-3

#: Views a planar start needs per camera: the interior has three unknowns (f, xp, yp) and each view's
#: homography gives two constraints on them.
MIN_VIEWS = 3

#: Points a view needs in each image: a homography has 8 unknowns (4 points), a pose 6; two more give
#: the view some redundancy.
MIN_POINTS = 6

#: The largest relative depth variation across the board (max depth / min depth − 1 over its observed
#: points) that, in EVERY view, leaves the focal length and the distance indistinguishable. A board
#: tilted by 10° at a range of twice its size varies by about 9 % in depth.
MIN_DEPTH_SPREAD = 0.03


def is_coplanar(xyz: np.ndarray) -> bool:
    """Whether points (N, 3), metres, lie (nearly) in one plane (:data:`COPLANAR_RATIO`)."""
    xyz = np.asarray(xyz, float)
    singular = np.linalg.svd(xyz - xyz.mean(axis=0), compute_uv=False)
    return bool(singular[0] == 0 or singular[-1] / singular[0] < COPLANAR_RATIO)


def camera_matrix(interior: Interior) -> tuple[np.ndarray, np.ndarray]:
    """:class:`Interior` → OpenCV's camera matrix (3, 3) and distortion (5,) k1, k2, p1, p2, k3
    (K1 = k1, K2 = k2, K3 = k3, P1 = p2_cv, P2 = −p1_cv; :mod:`usvips.core.interior`)."""
    matrix = np.array([[interior.f, 0.0, interior.xp], [0.0, interior.f / interior.sy, interior.yp], [0, 0, 1.0]])
    return matrix, np.array([interior.k1, interior.k2, -interior.p2, interior.p1, interior.k3])


def exterior_from_opencv(rvec: np.ndarray, tvec: np.ndarray) -> Exterior:
    """OpenCV's pose (Rodrigues vector, translation: x_cv = R·X + t) → our exterior orientation."""
    rotation = cv2.Rodrigues(np.asarray(rvec, float).reshape(3, 1))[0]
    centre = -rotation.T @ np.asarray(tvec, float).reshape(3)
    return Exterior(*centre, *angles_from_matrix(FLIP @ rotation))


def exterior_to_opencv(exterior: Exterior) -> tuple[np.ndarray, np.ndarray]:
    """Our exterior orientation → OpenCV's (Rodrigues vector, translation)."""
    rotation = FLIP @ exterior.rotation
    return cv2.Rodrigues(rotation)[0].reshape(3), -rotation @ exterior.position


@dataclass(frozen=True)
class PlaneFrame:
    """The target's plane: ``origin`` (3,), metres, and ``axes`` (3, 3) whose rows are the in-plane unit
    vectors e1, e2 and the normal n (object frame). Plane coordinates: axes · (X − origin)."""

    origin: np.ndarray
    axes: np.ndarray

    @classmethod
    def of(cls, xyz: np.ndarray) -> PlaneFrame:
        xyz = np.asarray(xyz, float)
        origin = xyz.mean(axis=0)
        axes = np.linalg.svd(xyz - origin)[2]
        if np.linalg.det(axes) < 0:
            axes[2] = -axes[2]
        return cls(origin, axes)

    def coordinates(self, xyz: np.ndarray) -> np.ndarray:
        """Plane coordinates (N, 3) of object points; the third is the distance off the plane."""
        return (np.asarray(xyz, float) - self.origin) @ self.axes.T


@dataclass(frozen=True)
class PlanarStart:
    """The start of both cameras from a planar target: ``interiors`` (left, right), each view's
    ``poses`` {(station, side): Exterior} (object frame), the median ``relative`` orientation, and each
    camera's pinhole reprojection ``rms_px`` (per coordinate)."""

    interiors: tuple[Interior, Interior]
    poses: dict[tuple[str, str], Exterior]
    relative: RelativeOrientation
    rms_px: tuple[float, float]

    def right_at(self, station: str) -> Exterior:
        """The right camera at ``station`` from the left one's pose and the median relative orientation."""
        return right_exterior(self.poses[(station, "l")], self.relative)


def _size_of(pixels: list[np.ndarray], image_size: tuple[int | None, int | None]) -> tuple[int, int]:
    """The image size (width, height) in pixels, or the extent of the observations when it is unknown."""
    if image_size[0] and image_size[1]:
        return int(image_size[0]), int(image_size[1])
    extent = np.max(np.vstack(pixels), axis=0)
    return int(np.ceil(extent[0])) + 1, int(np.ceil(extent[1])) + 1


def require_views(count: int) -> None:
    """Refuse fewer than :data:`MIN_VIEWS` views of a planar target, naming the alternatives."""
    if count < MIN_VIEWS:
        raise DegenerateGeometryError(
            f"the control points are (nearly) coplanar (a board) and seen in only {count} view(s): a start from a "
            f"planar target needs at least {MIN_VIEWS} views at different tilts (15-20 are recommended), or add "
            "points off the plane for the DLT")


def _view_rows(control: ControlPoints, observations: StereoObservations) -> dict[str, np.ndarray]:
    """Per station, its rows; refuses too few views, too few points in a view, one-camera points."""
    stations = observations.pair_labels
    require_views(len(stations))
    rows = {}
    for station in stations:
        index = np.flatnonzero([p == station for p in observations.pairs])
        for side, pixels in (("left", observations.left), ("right", observations.right)):
            bad = [observations.ids[i] for i in index if not np.all(np.isfinite(pixels[i]))]
            if bad:
                raise DegenerateGeometryError(
                    f"view {station!r}: target point {bad[0]!r} has no {side} pixel (seen by one camera only); "
                    "the calibration needs each point in both images of a view")
        if index.size < MIN_POINTS:
            raise DegenerateGeometryError(
                f"view {station!r}: only {index.size} target points in both images (at least {MIN_POINTS} "
                "needed); drop the view")
        rows[station] = index
    return rows


def depth_spread(plane_xy: np.ndarray, pixels: np.ndarray) -> float:
    """The board's relative depth variation in one view, max depth / min depth − 1 over its points, from
    the homography plane → image (its third row is proportional to each point's depth, whatever the
    camera's interior): 0 for a board parallel to the image plane."""
    homography, _ = cv2.findHomography(plane_xy.astype(np.float64), pixels.astype(np.float64), 0)
    if homography is None:
        return 0.0
    w = np.abs(plane_xy @ homography[2, :2] + homography[2, 2])
    return float(w.max() / max(w.min(), 1e-300) - 1.0)


def _require_tilt(plane: np.ndarray, observations: StereoObservations, rows: dict[str, np.ndarray]) -> None:
    spreads = {station: depth_spread(plane[index, :2], observations.left[index]) for station, index in rows.items()}
    if max(spreads.values()) < MIN_DEPTH_SPREAD:
        raise DegenerateGeometryError(
            f"all {len(rows)} views of the planar target are (nearly) parallel to the image plane (the board's depth "
            f"varies by at most {100 * max(spreads.values()):.1g} % across it in any view): the focal length and the "
            "distance cannot be told apart; tilt the board by 20-45° in several views")


def planar_start(control: ControlPoints, observations: StereoObservations,
                 image_size: tuple[int | None, int | None] = (None, None)) -> PlanarStart:
    """Both cameras' pinhole interior, every view's poses and the rig's relative orientation from views of
    a (nearly) planar target (module docstring). Raises :class:`DegenerateGeometryError` naming the view."""
    rows = _view_rows(control, observations)
    xyz = control.xyz[control.index_of(list(observations.ids), "observation")]
    frame = PlaneFrame.of(xyz)
    plane = frame.coordinates(xyz)
    plane[:, 2] = 0.0  # the start takes the target as flat; the adjustment uses its true coordinates
    _require_tilt(plane, observations, rows)
    stations = list(rows)
    flags = (cv2.CALIB_FIX_K1 | cv2.CALIB_FIX_K2 | cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST
             | cv2.CALIB_FIX_ASPECT_RATIO)
    interiors, poses, rms = [], {}, []
    for side, pixels in (("l", observations.left), ("r", observations.right)):
        objects = [plane[rows[s]].astype(np.float32) for s in stations]
        images = [pixels[rows[s]].astype(np.float32) for s in stations]
        size = _size_of(images, image_size)
        try:
            error, matrix, _, rvecs, tvecs = cv2.calibrateCamera(objects, images, size, np.eye(3), np.zeros(5),
                                                                 flags=flags)
        except cv2.error as failure:
            raise DegenerateGeometryError(f"the planar start of the {'left' if side == 'l' else 'right'} camera "
                                          f"failed: {str(failure).strip().splitlines()[-1]}") from None
        if not (np.all(np.isfinite(matrix)) and matrix[0, 0] > 0):
            raise DegenerateGeometryError(f"the planar start of the {'left' if side == 'l' else 'right'} camera "
                                          "found no focal length: the views do not fix the interior")
        interiors.append(Interior(float(matrix[0, 0]), float(matrix[0, 2]), float(matrix[1, 2])))
        rms.append(float(error / np.sqrt(2.0)))
        for station, rvec, tvec in zip(stations, rvecs, tvecs, strict=True):
            # plane coordinates p = A (X − o): x_cv = R p + t = (R A) X + (t − R A o)
            rotation = cv2.Rodrigues(rvec)[0] @ frame.axes
            translation = tvec.reshape(3) - rotation @ frame.origin
            poses[(station, side)] = exterior_from_opencv(cv2.Rodrigues(rotation)[0], translation)
    return PlanarStart((interiors[0], interiors[1]), poses, median_relative(poses, stations), (rms[0], rms[1]))


def median_relative(poses: dict[tuple[str, str], Exterior], stations: list[str]) -> RelativeOrientation:
    """The rig's relative orientation robustly from every view: the component-wise median of the base and
    the rotation closest to the element-wise median of the views' relative rotation matrices."""
    relatives = [relative_orientation(poses[(s, "l")], poses[(s, "r")]) for s in stations]
    base = np.median([r.base for r in relatives], axis=0)
    matrices = np.median([rotation_matrix(r.omega, r.phi, r.kappa) for r in relatives], axis=0)
    u, _, vt = np.linalg.svd(matrices)
    rotation = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
    return RelativeOrientation(*(float(b) for b in base), *angles_from_matrix(rotation))


def resect_views(control: ControlPoints, observations: StereoObservations, interior: Interior,
                 side: str = "l", minimum_views: int = MIN_VIEWS) -> dict[str, Exterior]:
    """Each view's pose of one camera (``side`` l/r) by a pinhole resection with a known interior
    (OpenCV's ``solvePnP`` with our distortion): the start of the board's poses in phase 2, where the
    housing's refraction is then fitted. Raises naming a view whose pose cannot be found."""
    if len(observations.pair_labels) < minimum_views:
        require_views(len(observations.pair_labels))
    matrix, distortion = camera_matrix(interior)
    pixels = observations.left if side == "l" else observations.right
    poses = {}
    for station in observations.pair_labels:
        index = np.flatnonzero([p == station for p in observations.pairs])
        xyz = control.xyz[control.index_of([observations.ids[i] for i in index], "observation")]
        if index.size < MIN_POINTS:
            raise DegenerateGeometryError(f"view {station!r}: only {index.size} target points in both images (at "
                                          f"least {MIN_POINTS} needed); drop the view")
        ok, rvec, tvec = cv2.solvePnP(xyz.reshape(-1, 1, 3).astype(np.float64),
                                      pixels[index].reshape(-1, 1, 2).astype(np.float64), matrix, distortion,
                                      flags=cv2.SOLVEPNP_ITERATIVE)
        if not ok:
            raise DegenerateGeometryError(f"view {station!r}: no pose of the {'left' if side == 'l' else 'right'} "
                                          "camera fits its target points")
        poses[station] = exterior_from_opencv(rvec, tvec)
    return poses
