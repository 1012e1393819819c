"""A rendered tank set-up with known truth: a stereo rig looking through a tank's flat glass wall at a board,
the same board pose photographed with the tank empty (air behind the glass) and filled (water), the cameras
unmoved; phase 1 in air from further board views. Metres, pixels (x right, y down)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tests.core import board_scenes
from usvips.core.calibration import CalibrationOptions, calibrate_air
from usvips.core.housing import FlatPortHousing, shared_plane_in_camera
from usvips.core.intersection import intersect
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.stereo_calibration import StereoCalibration

WALL_THICKNESS, WALL_INDEX, WATER_INDEX, NOISE_PX = 0.01, 1.5, 1.333, 0.3


def wall_rig(rig: board_scenes.BoardRig, rng, n3: float) -> board_scenes.BoardRig:
    """``rig`` behind one flat wall shared by both cameras (3-8 cm ahead of the left one, tilted a little),
    glass 10 mm of index 1.5, then a medium of index ``n3`` (1.0: the empty tank)."""
    d, e = rng.normal(0, 0.02, 2)
    g = rng.uniform(0.03, 0.08)

    def right(relative):
        plane = shared_plane_in_camera(d, e, g, relative.rotation, -relative.rotation @ relative.base)
        return FlatPortHousing(*plane, WALL_THICKNESS, WALL_INDEX, n3)

    return board_scenes.BoardRig(rig.left, rig.right, rig.relative, rig.size, "flat-port",
                                 (FlatPortHousing(d, e, g, WALL_THICKNESS, WALL_INDEX, n3), right))


def _joined(a: StereoObservations, b: StereoObservations) -> StereoObservations:
    return StereoObservations(a.ids + b.ids, np.vstack([a.left, b.left]), np.vstack([a.right, b.right]),
                              a.pairs + b.pairs)


@dataclass
class TankSetup:
    """The truth and the data: ``base`` (phase 1 from the air views, the tank view among them), ``water`` (the
    tank view filled), ``water_rig`` (the true rig behind the filled tank's wall), ``control`` (the board)."""

    control: ControlPoints
    base: StereoCalibration
    water: StereoObservations
    water_rig: board_scenes.BoardRig
    rng: np.random.Generator

    def held_out_errors(self, calibration: StereoCalibration) -> tuple[float, float]:
        """A board at a new place in the filled tank, intersected with ``calibration`` in the rig frame:
        (RMS relative error of the distances over 15 cm between its corners, error of the range from the left
        camera to the board's centre in metres)."""
        pose = board_scenes.random_views(self.control, self.water_rig, self.rng, 1, distances=(0.5, 1.0),
                                         tilts=(10.0, 40.0))[0]
        truth = self.water_rig.at(pose)
        left, right = truth.left.project(self.control.xyz), truth.right.project(self.control.xyz)
        seen = left.ok & right.ok
        noisy = [p.pixels[seen] + self.rng.normal(0, NOISE_PX, (int(seen.sum()), 2)) for p in (left, right)]
        rig = calibration.rig(frame="rig")
        points = intersect([rig.left, rig.right], noisy).points
        true = self.control.xyz[seen]
        i, j = np.triu_indices(len(true), 1)
        true_d, found_d = (np.linalg.norm(x[i] - x[j], axis=1) for x in (true, points))
        long = true_d > 0.15
        distance = float(np.sqrt(np.mean((found_d[long] / true_d[long] - 1.0) ** 2)))
        true_range = np.linalg.norm(true.mean(axis=0) - truth.left.exterior.position)
        return distance, float(np.linalg.norm(points.mean(axis=0)) - true_range)


def tank_setup(seed: int, air_views: int = 8) -> TankSetup:
    """A random rig (``board_scenes.random_rig``), a 9 × 6 board of 4 cm squares; phase 1 from
    ``air_views`` board views in air plus the tank view through the empty tank's wall (label ``tank0``)."""
    rng = np.random.default_rng(seed)
    control = board_scenes.board(9, 6, 0.04)
    rig = board_scenes.random_rig(rng)
    poses = board_scenes.random_views(control, rig, rng, air_views, distances=(0.5, 1.0))
    tank_pose = board_scenes.random_views(control, rig, rng, 1, distances=(0.6, 0.9), tilts=(10.0, 30.0))[0]
    wall_seed = int(rng.integers(1 << 30))
    empty, filled = (wall_rig(rig, np.random.default_rng(wall_seed), n3) for n3 in (1.0, WATER_INDEX))
    air = _joined(board_scenes.observe_views(control, rig, poses, rng, NOISE_PX),
                  board_scenes.observe_views(control, empty, [tank_pose], rng, NOISE_PX, prefix="tank"))
    base = calibrate_air(control, air, CalibrationOptions(image_size=rig.size)).calibration
    water = board_scenes.observe_views(control, filled, [tank_pose], rng, NOISE_PX, prefix="tank")
    return TankSetup(control, base, water, filled, rng)
