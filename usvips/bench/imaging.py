"""Benchmarks of the imaging core: enhancement pipeline, target pointing, conjugate matching."""

from __future__ import annotations

from collections.abc import Iterator

import cv2
import numpy as np

from usvips.bench import ratio_row
from usvips.core.camera import Camera, Exterior
from usvips.core.enhance import Pipeline
from usvips.core.housing import FlatPortHousing
from usvips.core.interior import Interior
from usvips.core.matching import epipolar_curve, match_along_curve
from usvips.core.rig import RelativeOrientation, StereoRig
from usvips.core.targets import locate_disc


def _frame(colour: bool, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    small = rng.integers(0, 256, (135, 240, 3) if colour else (135, 240), dtype=np.uint8)
    return cv2.resize(small, (1920, 1080), interpolation=cv2.INTER_CUBIC)


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    pipeline = Pipeline().then("clahe", clip_limit=2.0, tiles=8).then("gamma", gamma=0.8).then("median", size=3)
    lut = np.clip(np.rint(255 * (np.arange(256) / 255.0) ** 0.8), 0, 255).astype(np.uint8)
    clahe = cv2.createCLAHE(clipLimit=2.0, tileGridSize=(8, 8))
    for colour in (False, True):
        frame = _frame(colour)

        def bare(frame=frame, colour=colour) -> np.ndarray:
            if colour:
                ycc = cv2.cvtColor(frame, cv2.COLOR_RGB2YCrCb)
                ycc[:, :, 0] = clahe.apply(np.ascontiguousarray(ycc[:, :, 0]))
                out = cv2.cvtColor(ycc, cv2.COLOR_YCrCb2RGB)
            else:
                out = clahe.apply(frame)
            return cv2.medianBlur(cv2.LUT(out, lut), 3)

        yield ratio_row(f"enhancement pipeline CLAHE + gamma + median, 1920x1080 {'colour' if colour else 'grey'}",
                        1, lambda frame=frame: pipeline.apply(frame), bare,
                        "the same three OpenCV calls, bare", 1.2, repeats=25)

    # pointing: one click on a rendered disc target
    image = np.full((81, 81), 40, np.uint8)
    cv2.circle(image, (40 * 16 + 5, 40 * 16 - 3), 10 * 16, 220, -1, cv2.LINE_AA, 4)
    image = cv2.GaussianBlur(image, (0, 0), 1.0)
    template = image[30:51, 30:51].copy()
    clicks = 200
    yield ratio_row("target pointing (disc, 41 px window), per click", clicks,
                    lambda: [locate_disc(image, (41.0, 39.0)) for _ in range(clicks)],
                    lambda: [cv2.matchTemplate(image[20:61, 20:61], template, cv2.TM_CCOEFF_NORMED)
                             for _ in range(clicks)],
                    "cv2.matchTemplate of a 21 px template in the same 41 px window", None, repeats=3)

    # matching: one point along a refractive epipolar curve of a flat-port rig
    interior = Interior(800.0, 640.0, 480.0)
    left = Camera(interior, Exterior(0, 0, 0), FlatPortHousing(0, 0, 0.06, 0.016, 1.65, 1.34), 1280, 960)
    rig = StereoRig.from_relative(left, left, RelativeOrientation(0.3, 0, 0, 0, -0.05, 0))
    rng = np.random.default_rng(1)
    small = rng.integers(0, 256, (240, 320), dtype=np.uint8)
    texture = cv2.resize(small, (1280, 960), interpolation=cv2.INTER_CUBIC)
    pixel = (700.0, 480.0)
    curve = epipolar_curve(rig.left, rig.right, pixel, near=0.5, far=6.0)
    length = int(np.sum(np.linalg.norm(np.diff(curve.pixels, axis=0), axis=1)))
    template = texture[470:491, 690:711].copy()
    band = texture[470:491, 0:min(1280, length + 21)].copy()
    points = 20
    yield ratio_row(f"conjugate matching along a {length} px refractive epipolar curve, per point", points,
                    lambda: [match_along_curve(texture, texture, pixel, curve, window=21) for _ in range(points)],
                    lambda: [cv2.matchTemplate(band, template, cv2.TM_CCOEFF_NORMED) for _ in range(points)],
                    "cv2.matchTemplate along a straight band of the same length", None, repeats=3)
