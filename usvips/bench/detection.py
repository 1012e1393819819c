"""Detection rows (issue 35): the stereo pairing of one 1080p frame's detections through a flat port, batched
(:func:`usvips.core.detection.stereo.pair_detections`) against the same costs from one
:func:`usvips.core.matching.epipolar_curve` per keypoint (the unbatched construction), and the YOLO-pose
decoder on a full 640 × 640 head's output (8400 candidates) against an absolute target: a tenth of the
0.2 s a stereo frame may take at the 5 frames per second issue 35 asks for, for one image's decoding.
A third row refines every pair's snout and fork along the curve (:func:`usvips.core.detection.refine.refine_pairs`,
a 15 px patch matched near the model's right point) on textured 1080p images, against an absolute target:
half of the 0.2 s a stereo frame may take. These three rows time parts on made-up detections; the fourth
(:func:`usvips.bench.detection_frame.frame_row`) runs the shipped model and the whole per-frame path of
``usvips detect`` on rendered 1080p stereo frames of fish, against the 5 frames per second.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from usvips.bench import best_time, ratio_row
from usvips.bench.detection_frame import frame_row
from usvips.core.camera import Camera, Exterior
from usvips.core.detection import Detection, Keypoint, Letterbox, ModelDescription
from usvips.core.detection.refine import refine_pairs
from usvips.core.detection.registry import family
from usvips.core.detection.stereo import pair_detections
from usvips.core.housing import FlatPortHousing
from usvips.core.interior import Interior
from usvips.core.matching import epipolar_curve
from usvips.core.rig import RelativeOrientation, StereoRig

WIDTH, HEIGHT = 1920, 1080
NAMES = ("snout", "fork")
#: seconds one image's output may take to decode (a tenth of a stereo frame's 0.2 s at 5 frames per second)
DECODE_TARGET_S = 0.02
#: seconds refining a frame's pairs may take (half a stereo frame's 0.2 s at 5 frames per second)
REFINE_TARGET_S = 0.1


def _textured(rng: np.random.Generator) -> np.ndarray:
    """A grey 1080p image of smooth random texture (what a match needs; its content does not change the
    time much)."""
    import cv2

    noise = rng.uniform(0, 255, (HEIGHT // 8, WIDTH // 8)).astype(np.float32)
    return np.clip(cv2.resize(noise, (WIDTH, HEIGHT), interpolation=cv2.INTER_CUBIC), 0, 255).astype(np.uint8)


def _rig() -> StereoRig:
    interior = Interior(1400.0, 960.0, 540.0, 1.0, k1=-0.08)
    port = FlatPortHousing(0.01, -0.01, 0.05, 0.012, 1.5, 1.34)
    left = Camera(interior, Exterior(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), port, WIDTH, HEIGHT)
    return StereoRig.from_relative(left, left, RelativeOrientation(0.4, 0.0, 0.0, 0.0, -0.08, 0.0))


def _frame(rig: StereoRig, fish: int, rng: np.random.Generator) -> tuple[list[Detection], list[Detection]]:
    """``fish`` fish 1-3 m away seen by both cameras (0.3 px noise), as detections of each side."""
    left, right = [], []
    while len(left) < fish:
        bundle = rig.left.rays(np.array([[rng.uniform(100, WIDTH - 100), rng.uniform(100, HEIGHT - 100)]]))
        snout = bundle.origins[0] + rng.uniform(1.0, 3.0) * bundle.directions[0]
        body = np.vstack([snout, snout + [rng.uniform(0.2, 0.5), rng.normal(0, 0.1), 0.0]])
        seen = [rig.left.project(body), rig.right.project(body)]
        if bundle.ok[0] and all(s.ok.all() for s in seen):
            for side, projection in zip((left, right), seen, strict=True):
                pixels = projection.pixels + rng.normal(0, 0.3, (2, 2))
                side.append(Detection((*pixels.min(axis=0) - 10, *pixels.max(axis=0) + 10), "fish", 0.9,
                                      tuple(Keypoint(n, *p, 0.9) for n, p in zip(NAMES, pixels, strict=True))))
    order = rng.permutation(fish)
    return left, [right[i] for i in order]


def _costs_one_curve_at_a_time(rig: StereoRig, left: list[Detection], right: list[Detection]) -> np.ndarray:
    """The pairing costs from one epipolar curve per keypoint and direction (what the batch replaces)."""
    costs = np.zeros((len(left), len(right)))
    for i, a in enumerate(left):
        for name in NAMES:
            forward = epipolar_curve(rig.left, rig.right, a.keypoint(name).pixel, 0.3, 10.0, 100)
            costs[i] += [forward.distance_to(b.keypoint(name).pixel) ** 2 for b in right]
    for j, b in enumerate(right):
        for name in NAMES:
            backward = epipolar_curve(rig.right, rig.left, b.keypoint(name).pixel, 0.3, 10.0, 100)
            costs[:, j] += [backward.distance_to(a.keypoint(name).pixel) ** 2 for a in left]
    return np.sqrt(costs / (2 * len(NAMES)))


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    rng = np.random.default_rng(35)
    rig = _rig()
    fish = max(4, int(round(20 * min(scale, 1.0))))
    left, right = _frame(rig, fish, rng)
    paired = pair_detections(left, right, rig, gate_px=2.0)
    yield ratio_row(f"pair a 1080p stereo frame's {fish} + {fish} detections through a flat port", fish,
                    lambda: pair_detections(left, right, rig, gate_px=2.0),
                    lambda: _costs_one_curve_at_a_time(rig, left, right),
                    "the same costs from one epipolar curve per keypoint", 1.0, pairs=len(paired.pairs))
    description = ModelDescription("bench.onnx", "yolo-pose", 640, 640, ("fish",), ("snout", "fork", "upper caudal",
                                                                                     "lower caudal"))
    table = rng.uniform(0, 1, (1, 4 + 1 + 3 * 4, 8400))
    table[0, :4] *= 640
    table[0, 4] *= 0.3  # a few hundred candidates above the threshold, most overlapping
    letterbox = Letterbox.fit((WIDTH, HEIGHT), (640, 640))
    yolo = family("yolo-pose")
    found = yolo.decode(table, description, letterbox)
    ours_s = best_time(lambda: yolo.decode(table, description, letterbox))
    yield {"name": "decode a YOLO-pose output of 8400 candidates (640 × 640 input, 4 keypoints)", "n": 8400,
           "ours_s": round(ours_s, 6), "baseline": None, "baseline_s": None, "ratio": None, "target": None,
           "target_s": DECODE_TARGET_S, "met": bool(ours_s <= DECODE_TARGET_S), "detections": len(found)}
    left_image, right_image = _textured(rng), _textured(rng)

    def refine_all() -> list:
        return refine_pairs(left_image, right_image, paired.pairs, rig, NAMES, radius_px=8.0)

    refine_all()
    refine_s = best_time(refine_all)
    yield {"name": f"refine a 1080p stereo frame's {len(paired.pairs)} pairs' snout and fork along the curve",
           "n": len(paired.pairs), "ours_s": round(refine_s, 6), "baseline": None, "baseline_s": None, "ratio": None,
           "target": None, "target_s": REFINE_TARGET_S, "met": bool(refine_s <= REFINE_TARGET_S)}
    yield frame_row(scale)
