"""Stereo frames of fish with known truth for the pairing tests: a random calibrated rig of a housing kind
(its values drawn as tests/core/test_pointing_monte_carlo.py draws them), fish as 3-D snout/fork pairs
1-4 m in front of it imaged through the housing with pixel noise, distractor detections and missed ones."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.core import housing as housings
from usvips.core.calibration.model import stereo_cameras
from usvips.core.calibration.parameter_names import exterior_of
from usvips.core.camera import EXTERIOR_PARAMETERS, Exterior
from usvips.core.detection import Detection, Keypoint
from usvips.core.interior import INTERIOR_PARAMETERS
from usvips.core.rig import RelativeOrientation, relative_orientation, right_exterior
from usvips.core.stereo_calibration import ParameterEstimate, StereoCalibration

STATIONS = ("s0", "s1")
SIZE = (1280, 960)
NAMES = ("snout", "fork")


def _symbol(name: str) -> str:
    head = name.split("@")[0]
    return head.rsplit("_", 1)[0] if "_" in head else head


def random_calibration(rng: np.random.Generator, kind: str) -> StereoCalibration:
    """A true calibration (no covariance: the pointing is the only error) of a random rig of ``kind``."""
    values = {}
    for side in ("l", "r"):
        interior = {"f": rng.uniform(900, 1300), "xp": 640 + rng.normal(0, 15), "yp": 480 + rng.normal(0, 15),
                    "sy": 1 + rng.normal(0, 0.01), "k1": rng.normal(-0.08, 0.03), "k2": rng.normal(0, 0.02),
                    "p1": rng.normal(0, 1e-3), "p2": rng.normal(0, 1e-3), "k3": 0.0}
        values.update({f"{p}_{side}": interior[p] for p in INTERIOR_PARAMETERS})
    left = Exterior(rng.uniform(0.4, 0.8), rng.uniform(0.5, 0.9), rng.uniform(2.4, 2.9), *rng.normal(0, 0.04, 3))
    relative = RelativeOrientation(rng.uniform(0.3, 0.5), rng.normal(0, 0.01), rng.normal(0, 0.01),
                                   rng.normal(0, 0.01), rng.uniform(-0.15, -0.05), rng.normal(0, 0.01))
    for suffix, pose in (("_l", left), ("_r", right_exterior(left, relative)), ("_l@s1", left)):
        values.update({f"{p}{suffix}": getattr(pose, p) for p in EXTERIOR_PARAMETERS})
    cls = housings.kind(kind)
    for name in cls.calibration_names:
        spec = cls.spec(_symbol(name))
        value = spec.start + (0.3 * spec.sigma * rng.normal() if spec.sigma else 0.0)
        if spec.lower is not None:
            value = max(value, spec.lower + 0.5 * abs(spec.start - spec.lower))
        values[name] = value
    left_camera, right_camera = stereo_cameras(kind, values, STATIONS, STATIONS[0], SIZE)
    estimates = {name: ParameterEstimate(value, None, "free") for name, value in values.items()}
    poses = (left_camera.exterior, exterior_of(values, "l", "s1"))
    return StereoCalibration(left_camera, right_camera, STATIONS, poses,
                             relative_orientation(left_camera.exterior, right_camera.exterior), "water", 0.06,
                             estimates, None)


@dataclass
class Frame:
    """One stereo frame: the detections of each side, which fish each detection shows (−1: a distractor),
    every fish's true snout and fork (n, 2, 3) m, and the keypoints' pointing sigma (px)."""

    left: list[Detection]
    right: list[Detection]
    left_fish: list[int]
    right_fish: list[int]
    fish: np.ndarray
    sigma: dict[str, float]


def _detection(pixels: np.ndarray, rng: np.random.Generator) -> Detection:
    x0, y0 = pixels.min(axis=0) - 15
    x1, y1 = pixels.max(axis=0) + 15
    return Detection((float(x0), float(y0), float(x1), float(y1)), "fish", float(rng.uniform(0.3, 1.0)),
                     tuple(Keypoint(n, float(x), float(y), float(rng.uniform(0.5, 1.0)))
                           for n, (x, y) in zip(NAMES, pixels, strict=True)))


def random_frame(rng: np.random.Generator, calibration: StereoCalibration, fish: int = 8, distractors: int = 2,
                 missed: float = 0.1, ranges: tuple[float, float] = (1.0, 3.0),
                 lengths: tuple[float, float] = (0.25, 0.6)) -> Frame:
    """``fish`` fish ``ranges`` metres from the rig, ``lengths`` metres long, any heading, their keypoints'
    pixels with noise of a random sigma per keypoint (0.3-1 px), each detection missed with probability
    ``missed``, and ``distractors`` detections per side that are no fish; the right side's detections shuffled.

    The defaults keep a fish's depth sigma well below its length: beyond that (a 15 cm fish at 4 m behind a
    flat port) a length's stated σ, second order there, is conservative (NEES 0.5-0.8, see
    tests/core/test_second_order_sigma.py), whatever the pairing: 1-4 m and 0.15-0.6 m give NEES 0.7-1.0."""
    rig = calibration.rig(0, "object")
    sigma = {n: float(rng.uniform(0.3, 1.0)) for n in NAMES}
    bodies: list[np.ndarray] = []
    pixels: list[tuple[np.ndarray, np.ndarray]] = []
    while len(bodies) < fish:
        start = np.array([rng.uniform(150, 1130), rng.uniform(150, 810)])
        bundle = rig.left.rays(start[None])
        snout = bundle.origins[0] + rng.uniform(*ranges) * bundle.directions[0]
        heading = rng.normal(size=3)
        heading -= 0.7 * (heading @ bundle.directions[0]) * bundle.directions[0]  # mostly across the view
        fork = snout + rng.uniform(*lengths) * heading / np.linalg.norm(heading)
        body = np.vstack([snout, fork])
        left, right = rig.left.project(body), rig.right.project(body)
        inside = all(p.ok.all() and np.all((p.pixels > 20) & (p.pixels < np.array(SIZE) - 20)) for p in (left, right))
        if bundle.ok[0] and inside:
            bodies.append(body)
            pixels.append((left.pixels, right.pixels))
    noise = np.array([sigma[n] for n in NAMES])[:, None]
    frame = Frame([], [], [], [], np.array(bodies), sigma)
    for f, (left, right) in enumerate(pixels):
        for side, seen, owners in ((left, frame.left, frame.left_fish), (right, frame.right, frame.right_fish)):
            if rng.uniform() >= missed:
                seen.append(_detection(side + noise * rng.normal(size=(2, 2)), rng))
                owners.append(f)
    for seen, owners in ((frame.left, frame.left_fish), (frame.right, frame.right_fish)):
        for _ in range(distractors):
            snout = np.array([rng.uniform(50, 1230), rng.uniform(50, 910)])
            fork = np.clip(snout + rng.normal(0, 80, 2), 5, np.array(SIZE) - 5)
            seen.append(_detection(np.vstack([snout, fork]), rng))
            owners.append(-1)
    order = rng.permutation(len(frame.right))
    frame.right = [frame.right[i] for i in order]
    frame.right_fish = [frame.right_fish[i] for i in order]
    return frame
