"""Synthetic stereo views of a printed board with known truth (random rigs, housings, poses, noise).

The board's own frame is the object frame (metres; its corners on z = 0, x along its rows, y along its
columns); each view is a station: the rig placed so that the board sits in front of it at a random
distance, tilt and in-plane turn. Pixels: x right, y down, origin at the centre of the top-left pixel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.core.camera import Camera, Exterior
from usvips.core.housing import AirHousing, DomeCoverHousing, DomePortHousing, FlatPortHousing, shared_plane_in_camera
from usvips.core.interior import Interior
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.rig import RelativeOrientation, StereoRig, relative_orientation
from usvips.core.rotation import angles_from_matrix


def board(columns: int = 9, rows: int = 6, spacing: float = 0.03) -> ControlPoints:
    """A board's inner corners: ids "0" … (row-major), metres, z = 0."""
    xy = np.array([(c * spacing, r * spacing) for r in range(rows) for c in range(columns)])
    return ControlPoints(tuple(str(i) for i in range(len(xy))), np.column_stack([xy, np.zeros(len(xy))]))


@dataclass
class BoardRig:
    """The truth of one rig: interiors, relative orientation, housing kind and housings (or air), size."""

    left: Interior
    right: Interior
    relative: RelativeOrientation
    size: tuple[int, int]
    kind: str = "air"
    housings: tuple = (AirHousing(), AirHousing())

    def at(self, left_pose: Exterior) -> StereoRig:
        left = Camera(self.left, left_pose, self.housings[0], *self.size)
        right = Camera(self.right, left_pose, AirHousing(), *self.size)
        rig = StereoRig.from_relative(left, right, self.relative)
        right_housing = self.housings[1]
        if callable(right_housing):
            right_housing = right_housing(relative_orientation(rig.left.exterior, rig.right.exterior))
        return StereoRig(rig.left, Camera(self.right, rig.right.exterior, right_housing, *self.size))

    def in_water(self, kind: str, rng) -> BoardRig:
        """The same cameras behind housings of ``kind`` drawn within that kind's default priors."""
        n3 = rng.uniform(1.335, 1.345)
        if kind == "flat-port":
            t, n2 = 0.01, 1.5

            def port():
                return FlatPortHousing(*rng.normal(0, 0.01, 2), rng.uniform(0.03, 0.08), t, n2, n3)

            housings = (port(), port())
        elif kind == "dome-port":
            r, t, n2 = 0.05, 0.008, 1.49

            def dome():
                return DomePortHousing(*rng.normal(0, 0.002, 2), rng.normal(0, 0.004), r, t, n2, n3)

            housings = (dome(), dome())
        elif kind == "dome-cover":
            a, b, c, r = rng.normal(0, 0.002), rng.normal(0, 0.002), rng.uniform(0.015, 0.035), rng.uniform(0.08, 0.1)
            d, e = rng.normal(0, 0.008, 2)
            g = rng.uniform(0.02, 0.05) + r * np.sqrt(d * d + e * e + 1) - (d * a + e * b + c)
            n2 = 1.6
            sphere = rng.normal(0, 0.002), rng.normal(0, 0.002), rng.uniform(0.015, 0.035), rng.uniform(0.08, 0.1)

            def right(rel):
                plane = shared_plane_in_camera(d, e, g, rel.rotation, -rel.rotation @ rel.base)
                return DomeCoverHousing(*sphere, *plane, n2, n3)

            housings = (DomeCoverHousing(a, b, c, r, d, e, g, n2, n3), right)
        else:
            raise ValueError(kind)
        return BoardRig(self.left, self.right, self.relative, self.size, kind, housings)


def random_rig(rng, size: tuple[int, int] = (1280, 960)) -> BoardRig:
    """Two cameras 10-30 cm apart, toed in a little, f 0.8-1.2 × the image width, mild distortion."""
    width, height = size

    def interior():
        return Interior(f=rng.uniform(0.8, 1.2) * width, xp=width / 2 + rng.normal(0, 0.01 * width),
                        yp=height / 2 + rng.normal(0, 0.01 * width), sy=1.0 + rng.normal(0, 0.003),
                        k1=rng.uniform(-0.12, 0.02))
    relative = RelativeOrientation(rng.uniform(0.1, 0.3), rng.normal(0, 0.003), rng.normal(0, 0.005),
                                   rng.normal(0, 0.01), rng.uniform(-0.15, -0.03), rng.normal(0, 0.01))
    return BoardRig(interior(), interior(), relative, size)


def view_pose(control: ControlPoints, rig: BoardRig, rng, distance: float, tilt_deg: float) -> Exterior:
    """The left camera's pose that shows the board's centre near the middle of both images, ``distance``
    metres ahead, its normal tilted by ``tilt_deg`` about a random in-plane axis, turned in its plane."""
    centre = control.xyz.mean(axis=0)
    axis = rng.normal(size=2)
    axis = np.append(axis / np.linalg.norm(axis), 0.0)
    tilt = np.radians(tilt_deg)
    # Rodrigues rotation about the in-plane axis, then an in-plane turn (board → camera frame)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    turn = rng.uniform(-0.3, 0.3)
    spin = np.array([[np.cos(turn), -np.sin(turn), 0], [np.sin(turn), np.cos(turn), 0], [0, 0, 1]])
    board_to_camera = (np.eye(3) + np.sin(tilt) * k + (1 - np.cos(tilt)) * k @ k) @ spin
    # aim between the two cameras, a little off-centre
    half_base = 0.5 * rig.relative.base[0]
    spread = 0.15 * distance
    in_camera = np.array([half_base + rng.uniform(-spread, spread), rng.uniform(-spread, spread), -distance])
    position = centre - board_to_camera.T @ in_camera
    return Exterior(*position, *angles_from_matrix(board_to_camera))


def pixel_noise(rng, noise: float, shape, degrees: float | None = None) -> np.ndarray:
    """Pixel errors of standard deviation ``noise`` (px): Gaussian, or Student-t with ``degrees`` (> 2)
    degrees of freedom scaled to that standard deviation (heavy-tailed, as detected corners' errors)."""
    if degrees is None:
        return rng.normal(0, noise, shape)
    return noise * np.sqrt((degrees - 2.0) / degrees) * rng.standard_t(degrees, shape)


def observe_views(control: ControlPoints, rig: BoardRig, poses: list[Exterior], rng, noise: float,
                  prefix: str = "v", degrees: float | None = None) -> StereoObservations:
    """Noisy pixels of the board's corners seen in both images of each view (labels prefix + number); the
    noise is Gaussian of standard deviation ``noise`` (px), or Student-t (:func:`pixel_noise`)."""
    ids, left, right, pairs = [], [], [], []
    for k, pose in enumerate(poses):
        stereo = rig.at(pose)
        pl, pr = stereo.left.project(control.xyz), stereo.right.project(control.xyz)
        seen = np.flatnonzero(pl.ok & pr.ok)
        ids += [control.ids[i] for i in seen]
        left.append(pl.pixels[seen] + pixel_noise(rng, noise, (seen.size, 2), degrees))
        right.append(pr.pixels[seen] + pixel_noise(rng, noise, (seen.size, 2), degrees))
        pairs += [f"{prefix}{k}"] * seen.size
    return StereoObservations(tuple(ids), np.vstack(left), np.vstack(right), tuple(pairs))


def random_views(control: ControlPoints, rig: BoardRig, rng, count: int, distances=(0.4, 0.9),
                 tilts=(15.0, 45.0), minimum: int = 12) -> list[Exterior]:
    """``count`` view poses at distances (m) and tilts (degrees) drawn uniformly from the ranges, each
    showing at least ``minimum`` corners in both images (a detector would not report fewer)."""
    poses: list[Exterior] = []
    while len(poses) < count:
        pose = view_pose(control, rig, rng, rng.uniform(*distances), rng.uniform(*tilts))
        stereo = rig.at(pose)
        if np.sum(stereo.left.project(control.xyz).ok & stereo.right.project(control.xyz).ok) >= minimum:
            poses.append(pose)
    return poses
