"""A project of rendered stereo survey clips whose accepted objects are the renderer's true snout and fork, as
if a team had reviewed every fish: material with truth on which to try fine-tuning from a training-set export
(docs/detection.md, "Fine-tune on your team's reviewed fish"). No PyTorch needed:

    python -m usvips.training.rendered_reviews /tmp/reviewed_clips --clips 60
    usvips project export /tmp/reviewed_clips/acceptance.usvips /tmp/reviewed --format training-set

Clip i is :func:`usvips.core.synth.stereo_survey.survey_clip` of seed ``first + i`` (640 × 480, two frames 10
video frames apart), stored as a lossless stereo video with its exact calibration. On each frame, every fish a
detector must find in both images (:attr:`usvips.core.synth.fish_scene.FishTruth.required`) becomes an
accepted ``length`` object of two vertices at its true snout and fork pixels (a person's clicks without error);
other fish stay in the images, unlabelled.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from usvips.app.detection_acceptance import write_clip_project
from usvips.core.errors import UsvipsError
from usvips.core.synth.stereo_survey import SurveyClip, survey_clip
from usvips.store.opening import open_project
from usvips.store.records import Vertex

FIRST_SEED = 50_000_000  # used by no test, validation or shipped measurement
SIZE = (640, 480)


def accept_truth(project_path: Path, clips: list[SurveyClip]) -> int:
    """Add each clip's fish to find in both images as accepted lengths at their true pixels; returns how many."""
    added = 0
    with open_project(project_path) as project:
        for c, clip in enumerate(clips):
            label = f"clip{c}"
            for f, frame in enumerate(clip.frames):
                for left, right in zip(frame.left_truth, frame.right_truth, strict=True):
                    if not (left.required and right.required):
                        continue
                    vertices = [Vertex(float(left.keypoints[k, 0]), float(left.keypoints[k, 1]),
                                       float(right.keypoints[k, 0]), float(right.keypoints[k, 1]), pair=label,
                                       video=label, frame_left=f, frame_right=f, time_s=f / clip.fps)
                                for k in (0, 1)]
                    project.set_review(project.add_object("length", vertices, "fish"), "accepted")
                    added += 1
    return added


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="a new folder for the project and its videos")
    parser.add_argument("--clips", type=int, default=60)
    parser.add_argument("--first-seed", type=int, default=FIRST_SEED)
    args = parser.parse_args(argv)
    try:
        if args.clips < 1:
            raise UsvipsError(f"--clips {args.clips}: at least 1")
        if args.folder.exists():
            raise UsvipsError(f"{args.folder}: exists; the project is made in a new folder")
        clips = [survey_clip(args.first_seed + i, SIZE, frames=2, step=10) for i in range(args.clips)]
        path = write_clip_project(args.folder, clips)
        added = accept_truth(path, clips)
    except UsvipsError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(f"{path}: {added} accepted lengths on {args.clips} clips (seeds {args.first_seed}..)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
