"""Synthetic stereo rigs with known truth for the calibration tests (fixed seeds, stated noise)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.core.camera import Camera, Exterior
from usvips.core.housing import AirHousing, DomeCoverHousing, FlatPortHousing
from usvips.core.interior import Interior
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.rig import RelativeOrientation, StereoRig

NOISE_PX = 0.3
WIDTH, HEIGHT = 1280, 960
LEFT = Interior(f=1100.0, xp=652.0, yp=471.0, sy=1.02, k1=-0.09)
RIGHT = Interior(f=1085.0, xp=628.0, yp=488.0, sy=1.01, k1=-0.07)
RELATIVE = RelativeOrientation(0.4, 0.004, -0.01, 0.003, -0.12, 0.004)
FLAT = (FlatPortHousing(0.01, -0.015, 0.06, 0.016, 1.65, 1.34), FlatPortHousing(-0.012, 0.008, 0.07, 0.016, 1.65, 1.34))


def control_frame(n: int = 48, seed: int = 3) -> ControlPoints:
    """Targets on a 1.4 × 1.4 × 0.7 m frame (metres), the cameras 2-3 m away along +Z."""
    rng = np.random.default_rng(seed)
    xyz = np.column_stack([rng.uniform(0, 1.4, n), rng.uniform(0, 1.4, n), rng.uniform(-0.7, 0.0, n)])
    return ControlPoints(tuple(f"T{i}" for i in range(n)), xyz)


def station(k: int) -> Exterior:
    poses = [Exterior(0.5, 0.7, 2.6, 0.02, 0.03, 0.01), Exterior(0.3, 0.6, 2.9, -0.03, 0.06, 0.05),
             Exterior(0.6, 0.9, 2.4, 0.05, -0.02, -0.04)]
    return poses[k]


IN_AIR = (AirHousing(), AirHousing())


def rig_at(k: int, housings=IN_AIR) -> StereoRig:
    left = Camera(LEFT, station(k), housings[0], WIDTH, HEIGHT)
    right = Camera(RIGHT, station(k), housings[1], WIDTH, HEIGHT)
    return StereoRig.from_relative(left, right, RELATIVE)


@dataclass
class Pair:
    observations: StereoObservations
    rig: StereoRig


def observe(rig: StereoRig, points: np.ndarray, ids, label: str, seed: int, noise: float = NOISE_PX) -> Pair:
    rng = np.random.default_rng(seed)
    left, right = rig.left.project(points), rig.right.project(points)
    idx = np.flatnonzero(left.ok & right.ok)
    return Pair(StereoObservations(tuple(ids[i] for i in idx),
                                   left.pixels[idx] + rng.normal(0, noise, (idx.size, 2)),
                                   right.pixels[idx] + rng.normal(0, noise, (idx.size, 2)),
                                   (label,) * idx.size), rig)


def joined(pairs: list[Pair]) -> StereoObservations:
    obs = [p.observations for p in pairs]
    return StereoObservations(sum((o.ids for o in obs), ()), np.vstack([o.left for o in obs]),
                              np.vstack([o.right for o in obs]), sum((o.pairs for o in obs), ()))


def dome_housings() -> tuple[DomeCoverHousing, DomeCoverHousing]:
    left = DomeCoverHousing(0.002, -0.001, 0.02, 0.09, 0.0, 0.0, 0.12, 1.6, 1.34)
    return left, left
