"""Stereo rigs: two cameras whose relative orientation and housings travel together.

The rig frame is the left camera's frame (origin at the left perspective centre, left camera axes).
A rig pose (an :class:`Exterior` of the left camera) places the whole rig in object space; the right
camera's exterior follows from the relative orientation. Housings are held in each camera's own frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.core.camera import Camera, Exterior
from usvips.core.rotation import angles_from_matrix, rotation_matrix


@dataclass(frozen=True)
class RelativeOrientation:
    """The right camera in the left camera's frame: its centre (bx, by, bz) in metres and the angles
    (omega, phi, kappa, radians) of its rotation M_rel (left frame → right image frame)."""

    bx: float
    by: float = 0.0
    bz: float = 0.0
    omega: float = 0.0
    phi: float = 0.0
    kappa: float = 0.0

    @property
    def rotation(self) -> np.ndarray:
        return rotation_matrix(self.omega, self.phi, self.kappa)

    @property
    def base(self) -> np.ndarray:
        return np.array([self.bx, self.by, self.bz])


def right_exterior(left: Exterior, relative: RelativeOrientation) -> Exterior:
    """Exterior orientation of the right camera given the left camera's and the relative orientation."""
    m_right = relative.rotation @ left.rotation
    centre = left.to_object(relative.base[None, :])[0]
    omega, phi, kappa = angles_from_matrix(m_right)
    return Exterior(*centre, omega, phi, kappa)


def relative_orientation(left: Exterior, right: Exterior) -> RelativeOrientation:
    """The relative orientation that carries ``left`` into ``right``."""
    base = left.to_camera(right.position[None, :])[0]
    m_rel = right.rotation @ left.rotation.T
    return RelativeOrientation(*base, *angles_from_matrix(m_rel))


@dataclass(frozen=True)
class StereoRig:
    """Two cameras (interior + housing each) and their relative orientation."""

    left: Camera
    right: Camera

    @classmethod
    def from_relative(cls, left: Camera, right_template: Camera, relative: RelativeOrientation) -> StereoRig:
        return cls(left, right_template.with_exterior(right_exterior(left.exterior, relative)))

    @property
    def relative(self) -> RelativeOrientation:
        return relative_orientation(self.left.exterior, self.right.exterior)

    def at_pose(self, left_exterior: Exterior) -> StereoRig:
        """The same rig moved so that the left camera has ``left_exterior``."""
        relative = self.relative
        return StereoRig(self.left.with_exterior(left_exterior),
                         self.right.with_exterior(right_exterior(left_exterior, relative)))

    @property
    def cameras(self) -> tuple[Camera, Camera]:
        return (self.left, self.right)
