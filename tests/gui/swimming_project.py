"""A project holding a stereo video of a rendered swimming, bending fish with known truth (encoded
losslessly, the right camera started ``OFFSET`` frames earlier) and a length measured on it by the truth's
pixels: the window's tracking and instants are tested on it."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tests.core.test_tracking import truth, video
from usvips.app.video_project import add_video
from usvips.core.measurements import measure_picks
from usvips.core.stereo_calibration import StereoCalibration
from usvips.core.synth.swimming import SwimmingFish
from usvips.io.calibration_file import calibration_to_dict
from usvips.io.video_writer import encode_video
from usvips.store import Project
from usvips.store.project import Vertex

FRAMES, OFFSET, START = 24, 2, 6
POINTS = (0.3, 0.45)  # the measured body points, as fractions of the fork length from the snout


#: a plain grey patch (x0, y0, x1, y1 px) painted on every frame of both cameras: a featureless place
BLANK = (12, 12, 60, 60)


def _painted(image: np.ndarray) -> np.ndarray:
    image = np.repeat(image[:, :, None], 3, axis=2)
    x0, y0, x1, y1 = BLANK
    image[y0:y1, x0:x1] = 128
    return image


def make_survey_project(folder: Path, seed: int = 7):
    """The project file, the measured length's id, the fish and the rig (the length measured on frame
    ``START`` by the truth's pixels of the body points ``POINTS``)."""
    fish = SwimmingFish(start=(0.25, 0.0, -1.0), length=0.36, speed=0.15, bend=0.3, seed=seed)
    stereo, frames = video(fish)
    left = [_painted(frames(i)[0]) for i in range(FRAMES)]
    right = [_painted(frames(max(i - OFFSET, 0))[1]) for i in range(FRAMES)]
    encode_video(folder / "left.mkv", left, 25.0, "ffv1")
    encode_video(folder / "right.mkv", right, 25.0, "ffv1")
    calibration = StereoCalibration.from_cameras(stereo.left, stereo.right, "water", 0.3)
    path = folder / "survey.usvips"
    with Project.create(path) as project:
        add_video(project, [folder / "left.mkv"], [folder / "right.mkv"], "drop")
        project.set_video_offset("drop", OFFSET)
        calibration_id = project.add_calibration("cal", calibration_to_dict(calibration), ("drop",))
        picks = [truth(stereo, fish, START, f * fish.length) for f in POINTS]
        m = measure_picks("length", calibration, np.array([p[0] for p in picks]), np.array([p[1] for p in picks]),
                          0, "rig")
        vertices = [Vertex(*p[0], *p[1], tuple(xyz), m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3], calibration_id,
                           "drop", "drop", START, START + OFFSET, START / 25.0)
                    for i, (p, xyz) in enumerate(zip(picks, m.points, strict=True))]
        object_id = project.add_object("length", vertices, "Pagrus auratus")
    return path, object_id, fish, stereo
