"""Measure how a detection model's REFINED STEREO keypoints err, by the fish's size, on rendered survey clips
with truth, and write the ``[stereo_sigma]`` table its lengths' σ rests on (docs/detection.md, "The σ fish
by fish").

Each clip (:func:`usvips.core.synth.stereo_survey.survey_clip`, seeds the caller chooses: never the
acceptance test's nor the bench's) is run frame by frame as ``usvips detect`` runs it
(:func:`usvips.app.detection_service.pair_and_refine`: detection in both images, pairing through the housing,
refinement along the curve with its limits). Of the pairs that get a length — both detections the same true
fish (:func:`usvips.app.detection_acceptance.assign`), no keypoint refused or at the image's edge — each
keypoint gives:

- the LEFT keypoint's error (image px, about the fish's true keypoint), at the fish's snout–fork length in
  the left image from the MODEL's keypoints (what a proposal knows), both taken to the model's input pixels;
- when its right keypoint was refined, the MATCH's error: the right error minus the left error (image px),
  what the right point errs by about the left point's conjugate;
- when it was not (the match refused, the model's point kept), the right keypoint's own error (image px).

Each is fitted as σ(s) = √(a² + (b·s)²) by maximum likelihood
(:func:`usvips.core.detection.keypoint_sigma.fit_size_sigma`): the errors' second moment by size, gross misses
counted. Run::

    python -m usvips.training.stereo_sigma --model resources/models/fish-centre-pose.toml \\
        --seeds 61000000 120 --out /tmp/fish-with-stereo-sigma.toml

The output is the description with the table added, or replacing the one it had (its model file beside it is
not copied: put the table into the shipped description); it never writes over its input. A model that has a
table already keeps using it for refinement's limits while the errors are collected (they grow with the
fish's size, :func:`usvips.app.detection_service.shift_limits`). Pixels: x right, y down.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from usvips.app.detection_acceptance import assign
from usvips.app.detection_model import DetectionModel, load_model
from usvips.app.detection_service import KEYPOINTS, _disagreement, pair_and_refine
from usvips.app.pair_geometry import PairGeometry
from usvips.core.detection.keypoint_sigma import StereoSigma, fit_size_sigma
from usvips.core.errors import UsvipsError
from usvips.core.stereo_calibration import StereoCalibration
from usvips.core.synth.stereo_survey import survey_clip
from usvips.training.description_tables import without_table


@dataclass
class StereoErrors:
    """What the clips gave, per keypoint of :data:`KEYPOINTS`: the fish's size (left image px, from the
    model's keypoints) and the left keypoint's error (2,) image px of every pair with a length; the size and
    the match's error (2,) image px of those refined in the right image; and the counts."""

    clips: int = 0
    pairs: int = 0
    left_size: dict[str, list[float]] = field(default_factory=lambda: {k: [] for k in KEYPOINTS})
    left_error: dict[str, list[np.ndarray]] = field(default_factory=lambda: {k: [] for k in KEYPOINTS})
    match_size: dict[str, list[float]] = field(default_factory=lambda: {k: [] for k in KEYPOINTS})
    match_error: dict[str, list[np.ndarray]] = field(default_factory=lambda: {k: [] for k in KEYPOINTS})
    unmatched_size: dict[str, list[float]] = field(default_factory=lambda: {k: [] for k in KEYPOINTS})
    unmatched_error: dict[str, list[np.ndarray]] = field(default_factory=lambda: {k: [] for k in KEYPOINTS})

    def save(self, path: Path) -> None:
        """Keep the errors (``.npz``) so that the table can be fitted again without running the model."""
        arrays = {f"{part}.{k}": np.asarray(getattr(self, part)[k], dtype=np.float64) for part in _PARTS
                  for k in KEYPOINTS}
        np.savez_compressed(path, clips=self.clips, pairs=self.pairs, **arrays)

    @classmethod
    def load(cls, path: Path) -> StereoErrors:
        with np.load(path) as data:
            errors = cls(int(data["clips"]), int(data["pairs"]))
            for part in _PARTS:
                getattr(errors, part).update({k: list(data[f"{part}.{k}"]) for k in KEYPOINTS})
        return errors


_PARTS = ("left_size", "left_error", "match_size", "match_error", "unmatched_size", "unmatched_error")


def collect_errors(model: DetectionModel, seeds: Iterable[int], size: tuple[int, int] = (640, 480),
                   frames: int = 4, step: int = 2, fps: float = 25.0,
                   progress: Callable[[str], None] | None = None) -> StereoErrors:
    """Run ``model`` on the clip of each seed (``frames`` frames ``step`` video frames apart, ``size`` px) and
    collect the errors (see the module docstring)."""
    errors = StereoErrors()
    detector = model.make_detector()
    for seed in seeds:
        clip = survey_clip(int(seed), size, frames, fps, step)
        calibration = StereoCalibration.from_cameras(clip.rig.left, clip.rig.right, "water", 0.3, station="s1")
        geometry = PairGeometry(calibration, 0, 0, "rig")
        for frame in clip.frames:
            results, _, _, _ = pair_and_refine(frame.left, frame.right, geometry, model, detector)
            for result in results:
                if _disagreement(result):
                    continue
                left = np.array([result.pair.left.keypoint(k).pixel for k in KEYPOINTS])
                right = np.array([result.pair.right.keypoint(k).pixel for k in KEYPOINTS])
                model_right = np.array([next(s.before for s in result.keypoints if s.name == k) for k in KEYPOINTS])
                fish = assign(left[None], frame.left_truth)[0]
                if fish is None or assign(model_right[None], frame.right_truth)[0] != fish:
                    continue
                errors.pairs += 1
                length = float(np.linalg.norm(left[1] - left[0]))
                refined = {s.name: s.refined for s in result.keypoints}
                for k, name in enumerate(KEYPOINTS):
                    left_error = left[k] - frame.left_truth[fish].keypoints[k]
                    errors.left_size[name].append(length)
                    errors.left_error[name].append(left_error)
                    right_error = right[k] - frame.right_truth[fish].keypoints[k]
                    if refined.get(name):
                        errors.match_size[name].append(length)
                        errors.match_error[name].append(right_error - left_error)
                    else:
                        errors.unmatched_size[name].append(length)
                        errors.unmatched_error[name].append(right_error)
        errors.clips += 1
        if progress is not None:
            progress(f"clip {seed} ({clip.kind}): {errors.pairs} pairs with a length so far")
    return errors


def fit_stereo_sigma(errors: StereoErrors, input_per_image_px: float, basis: str) -> StereoSigma:
    """The :class:`StereoSigma` of ``errors``: each keypoint's left σ by size in the model's input pixels
    (``input_per_image_px``: the letterbox's scale of the clips' frames), its match σ by size in image px."""
    scale = float(input_per_image_px)
    left = {k: fit_size_sigma(np.array(errors.left_size[k]) * scale, np.array(errors.left_error[k]) * scale)
            for k in KEYPOINTS}
    match = {k: fit_size_sigma(np.array(errors.match_size[k]), np.array(errors.match_error[k])) for k in KEYPOINTS}
    unmatched = {k: fit_size_sigma(np.array(errors.unmatched_size[k]) * scale,
                                   np.array(errors.unmatched_error[k]) * scale) for k in KEYPOINTS}
    return StereoSigma(left, match, basis, unmatched)


def stereo_sigma_table(stereo: StereoSigma) -> str:
    """The ``[stereo_sigma]`` TOML table of ``stereo``."""
    def pairs(table: dict) -> str:
        return ", ".join(f'"{k}" = [{v.a:.4g}, {v.b:.4g}]' for k, v in table.items())

    basis = stereo.basis.replace("\\", "\\\\").replace('"', '\\"')
    return (f"\n[stereo_sigma]  # measured by usvips.training.stereo_sigma; sigma(s) = sqrt(a^2 + (b s)^2)\n"
            f'basis = "{basis}"\n'
            f"left = {{{pairs(stereo.left)}}}  # the left keypoint, model input px; s in input px\n"
            f"match = {{{pairs(stereo.match)}}}  # the refined right keypoint about the left's conjugate, image px\n"
            f"unmatched = {{{pairs(stereo.unmatched)}}}  # a right keypoint not refined, model input px\n")


def without_stereo_sigma(text: str) -> str:
    """A description's text without its ``[stereo_sigma]`` table (from its header, and the comment lines just
    above it, to the next table or the end): the table a new fit replaces. The model is still loaded with the
    old table, whose σ by size sets refinement's limits while the errors are collected
    (:func:`usvips.app.detection_service.shift_limits`): the new table describes the pairs those limits
    pass."""
    return without_table(text, "stereo_sigma")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m usvips.training.stereo_sigma",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", required=True, help="the model's description file (.toml)")
    parser.add_argument("--seeds", nargs=2, type=int, metavar=("FIRST", "COUNT"), required=True,
                        help="the clips' seeds: FIRST, FIRST+1, ... (never the acceptance test's or the bench's)")
    parser.add_argument("--out", required=True, help="the description with [stereo_sigma] added (a new file)")
    parser.add_argument("--frames", type=int, default=4)
    parser.add_argument("--errors", help="keep the collected errors in this .npz file (or, when it exists, fit "
                                         "from it without running the model)")
    args = parser.parse_args(argv)
    try:
        source, out = Path(args.model), Path(args.out)
        if out.resolve() == source.resolve():
            raise UsvipsError(f"{out}: would write over the model's description; name a new file")
        text = without_stereo_sigma(source.read_text(encoding="utf-8"))
        model = load_model(source)
        first, count = args.seeds
        if count < 1:
            raise UsvipsError(f"--seeds: COUNT must be >= 1, got {count}")
        kept = Path(args.errors) if args.errors else None
        if kept is not None and kept.is_file():
            errors = StereoErrors.load(kept)
        else:
            errors = collect_errors(model, range(first, first + count), frames=args.frames,
                                    progress=lambda line: print(line, file=sys.stderr, flush=True))
            if kept is not None:
                errors.save(kept)
        basis = (f"{errors.pairs} pairs with a length on {errors.clips} rendered stereo survey clips of 640 x 480, "
                 f"seeds {first}..{first + count - 1}")
        stereo = fit_stereo_sigma(errors, model.input_scale((640, 480)), basis)
        out.write_text(text.rstrip("\n") + "\n" + stereo_sigma_table(stereo), encoding="utf-8")
    except UsvipsError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(json.dumps({"pairs": errors.pairs, "clips": errors.clips,
                      "left": {k: [v.a, v.b, v.n] for k, v in stereo.left.items()},
                      "match": {k: [v.a, v.b, v.n] for k, v in stereo.match.items()},
                      "unmatched": {k: [v.a, v.b, v.n] for k, v in stereo.unmatched.items()}}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
