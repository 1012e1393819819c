"""Rendered stereo survey clips with truth: the fish scenes of :mod:`usvips.core.synth.fish_scene` seen by a
random stereo rig of one housing kind, the fish swimming straight on for a few frames of a video, each frame
rendered through both cameras with each fish's keypoints (image pixels, visibility) and object points.

The rig: the left camera is :func:`usvips.core.synth.fish_scene.random_camera` (a random field of view,
distortion and tilt); the right one has the same lens and housing, 0.2-0.5 m to its right, turned in by
1-6° with a little roll and pitch. The scene is drawn in front of the left camera, so some fish are seen by
one camera only (as in a survey). Each fish swims along its heading at 0.1-0.6 m/s; the seabed, weed and
rocks stay. One scene seed draws every image's seabed texture, particles and noise (the renderer draws them
from it in that order), so the seabed is the same in both images and on every frame; the noise is too (1-5
grey levels: it does not move with the scene, so it cannot pass for a match).

Metres, seconds; pixels x right, y down, origin at the centre of the top-left pixel. Deterministic for a
seed.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from usvips.core import housing as housings
from usvips.core.rig import RelativeOrientation, StereoRig
from usvips.core.synth.fish_scene import FishScene, FishTruth, random_camera, random_scene, render_fish_scene

#: the rig's baseline (m), toe-in (radians) and the fish's swimming speed (m/s) the clips draw from
BASELINE_M = (0.2, 0.5)
TOE_IN_RAD = (0.02, 0.1)
SPEED_M_S = (0.1, 0.6)


@dataclass(frozen=True)
class StereoFrame:
    """One frame of a clip: the left and right images (8-bit BGR) and each fish's truth in each (same
    order as the clip's fish)."""

    left: np.ndarray
    right: np.ndarray
    left_truth: tuple[FishTruth, ...]
    right_truth: tuple[FishTruth, ...]


@dataclass(frozen=True)
class SurveyClip:
    """A rendered stereo clip: its ``rig`` (the left camera at the scene's origin), housing ``kind``, frame
    rate (frames/s) and ``frames``; fish i is the same fish on every frame."""

    rig: StereoRig
    kind: str
    fps: float
    frames: tuple[StereoFrame, ...]

    @property
    def fish_count(self) -> int:
        return len(self.frames[0].left_truth) if self.frames else 0


def random_rig(rng: np.random.Generator, kind: str, size: tuple[int, int]) -> StereoRig:
    """A random stereo rig of housing ``kind`` (see the module docstring), frames of ``size`` (width, height)."""
    left = random_camera(rng, kind, size)
    relative = RelativeOrientation(float(rng.uniform(*BASELINE_M)), float(rng.normal(0, 0.005)),
                                   float(rng.normal(0, 0.01)), float(rng.normal(0, 0.01)),
                                   -float(rng.uniform(*TOE_IN_RAD)), float(rng.normal(0, 0.01)))
    return StereoRig.from_relative(left, left, relative)


def _moved(scene: FishScene, offsets: np.ndarray) -> FishScene:
    fish = tuple(replace(f, snout=tuple(np.asarray(f.snout) + d)) for f, d in zip(scene.fish, offsets, strict=True))
    return replace(scene, fish=fish)


def survey_clip(seed: int, size: tuple[int, int] = (640, 480), frames: int = 4, fps: float = 25.0,
                step: int = 1, kind: str | None = None, fish: tuple[int, int] = (1, 6)) -> SurveyClip:
    """The clip of ``seed``: ``frames`` frames ``step`` video frames apart (at ``fps``) of a random scene
    (``fish``: fewest, most) through a random rig; the housing ``kind`` is the seed's turn among the kinds
    unless given."""
    kinds = housings.names()
    kind = kind or kinds[seed % len(kinds)]
    rng = np.random.default_rng(seed)
    rig = random_rig(rng, kind, size)
    scene = random_scene(rng, rig.left, fish=fish)
    velocity = np.array([np.asarray(f.heading) * rng.uniform(*SPEED_M_S) for f in scene.fish]).reshape(-1, 3)
    out = []
    for i in range(frames):
        now = _moved(scene, velocity * i * step / fps)
        left, left_truth = render_fish_scene(rig.left, now, size)
        right, right_truth = render_fish_scene(rig.right, now, size)
        out.append(StereoFrame(left, right, tuple(left_truth), tuple(right_truth)))
    return SurveyClip(rig, kind, float(fps) / step, tuple(out))
