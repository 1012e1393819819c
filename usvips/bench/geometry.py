"""Benchmarks of the camera model: refractive intersection and back-projection against OpenCV."""

from __future__ import annotations

from collections.abc import Iterator

import cv2
import numpy as np

from usvips.bench import ratio_row
from usvips.core.camera import Camera, Exterior
from usvips.core.housing import AirHousing, DomeCoverHousing, FlatPortHousing
from usvips.core.interior import Interior
from usvips.core.intersection import intersect
from usvips.core.rig import RelativeOrientation, StereoRig


def _rig(housing_left, housing_right) -> StereoRig:
    interior = Interior(f=1000.0, xp=640.0, yp=480.0, sy=1.0, k1=-0.08, k2=0.02, p1=2e-4, p2=-1e-4)
    left = Camera(interior, Exterior(0.0, 0.0, 0.0, 0.02, -0.03, 0.01), housing_left, 1280, 960)
    right = Camera(interior, left.exterior, housing_right, 1280, 960)
    return StereoRig.from_relative(left, right, RelativeOrientation(0.4, 0.0, 0.0, 0.0, -0.08, 0.0))


def _pinhole_matrices(rig: StereoRig) -> tuple[np.ndarray, np.ndarray]:
    mats = []
    for cam in rig.cameras:
        interior = cam.interior
        k = np.array([[interior.f, 0, interior.xp], [0, interior.f / interior.sy, interior.yp], [0, 0, 1]])
        # OpenCV's camera frame: x right, y down, z forward = diag(1, −1, −1) · ours
        flip = np.diag([1.0, -1.0, -1.0])
        rot = flip @ cam.exterior.rotation
        mats.append((k, rot, -rot @ cam.exterior.position))
    return mats


def _scene(rig: StereoRig, n: int, seed: int = 7) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n points seen by both cameras: left pixels over the frame at 1.5-4 m along their rays."""
    rng = np.random.default_rng(seed)
    count = int(n * 1.6)
    pixels = np.column_stack([rng.uniform(0, 1279, count), rng.uniform(0, 959, count)])
    rays = rig.left.rays(pixels)
    points = rays.origins + rng.uniform(1.5, 4.0, count)[:, None] * rays.directions
    left = rig.left.project(points)
    right = rig.right.project(points)
    keep = np.flatnonzero(rays.ok & left.ok & right.ok)[:n]
    # the left pixels the points were traced from (the truth that back-projection must return to)
    return points[keep], pixels[keep], right.pixels[keep]


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    n = max(1000, int(100_000 * scale))
    pairs = ((FlatPortHousing(0.0, 0.0, 0.08, 0.016, 1.65, 1.34),
              FlatPortHousing(0.01, -0.005, 0.08, 0.016, 1.65, 1.34)),
             (DomeCoverHousing(0.001, -0.002, 0.03, 0.09, 0.004, -0.003, 0.11, 1.6, 1.34),
              DomeCoverHousing(-0.002, 0.001, 0.03, 0.09, 0.01, 0.002, 0.12, 1.6, 1.34)))
    housings = {left.kind: (left, right) for left, right in pairs}
    air = _rig(AirHousing(), AirHousing())
    cv_left, cv_right = _pinhole_matrices(air)
    proj_left = cv_left[0] @ np.column_stack([cv_left[1], cv_left[2]])
    proj_right = cv_right[0] @ np.column_stack([cv_right[1], cv_right[2]])
    for label, (h_left, h_right) in housings.items():
        rig = _rig(h_left, h_right)
        points, pix_left, pix_right = _scene(rig, n)
        count = len(points)

        def ours_intersect(rig=rig, pl=pix_left, pr=pix_right) -> object:
            return intersect(rig.cameras, [pl, pr], 0.5)

        def cv_triangulate(pl=pix_left, pr=pix_right) -> object:
            return cv2.triangulatePoints(proj_left, proj_right, pl.T.copy(), pr.T.copy())

        result = intersect(rig.cameras, [pix_left, pix_right], 0.5)
        error = float(np.max(np.linalg.norm(result.points - points, axis=1)))
        yield ratio_row(f"intersection ({label}): trace 2 rays, intersect, covariance", count,
                        ours_intersect, cv_triangulate, "cv2.triangulatePoints (pinhole pair)", 0.5,
                        max_error_m=error)

        camera = rig.left
        rvec, _ = cv2.Rodrigues(cv_left[1])
        tvec = cv_left[2]
        k = cv_left[0]
        dist = np.array([camera.interior.k1, camera.interior.k2, -camera.interior.p2, camera.interior.p1])

        def ours_project(camera=camera, points=points) -> object:
            return camera.project(points)

        def cv_project(points=points, rvec=rvec, tvec=tvec, k=k, dist=dist) -> object:
            return cv2.projectPoints(points, rvec, tvec, k, dist)

        back = camera.project(points)
        yield ratio_row(f"back-projection ({label}): object point -> pixel through the housing", count,
                        ours_project, cv_project, "cv2.projectPoints (pinhole with distortion)", 3.0,
                        axial=camera.housing.axis is not None, max_error_px=float(
                            np.max(np.abs(back.pixels - pix_left))))
