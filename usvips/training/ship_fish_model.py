"""Ship a trained fish model: measure it on held-out rendered frames through the ONNX runner (OpenCV's DNN
module, exactly as USVIPS runs it), choose its score threshold on one set of seeds and report its figures on
another, and write the model, its description (with the measured pointing σ per keypoint) and the training's
record into the output folder. Needs no PyTorch:

    nice -n 10 python -m usvips.training.ship_fish_model --trained /tmp/fish_run --out resources/models

Seeds: the tuning frames are 10_000_000 + i, the reported held-out frames 20_000_000 + i (the training renders
from its own seed sequence); the test of the shipped model uses others again.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from usvips.core.detection.letterbox import Letterbox
from usvips.core.detection.runner import OnnxDetector
from usvips.core.detection.validation import ValidationFigures, match_image
from usvips.core.synth.fish_scene import KEYPOINTS
from usvips.core.synth.fish_validation import validation_frame
from usvips.io.model_description import read_model_description

NAME = "fish-centre-pose"
SIZE = (640, 480)
TUNING_SEEDS = 10_000_000
REPORTED_SEEDS = 20_000_000
THRESHOLDS = (0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6)


def _runs(detector: OnnxDetector, seeds: range) -> list[tuple[tuple, list]]:
    """Each frame's detections at the lowest threshold and its truth."""
    out = []
    for seed in seeds:
        image, truths = validation_frame(seed, SIZE)
        out.append((detector.detect(image), [t.true_object() for t in truths]))
    return out


def _figures(runs: list, threshold: float, scale: float) -> ValidationFigures:
    figures = ValidationFigures()
    for detections, truths in runs:
        match_image([d for d in detections if d.score >= threshold], truths, figures, scale=scale)
    return figures


def _choose(runs: list, scale: float) -> float:
    """The threshold with the best recall among those with precision ≥ 0.9 on the tuning frames (else the
    one with the best F1 score, the harmonic mean of recall and precision)."""
    scored = [(t, _figures(runs, t, scale)) for t in THRESHOLDS]
    good = [(f.recall, t) for t, f in scored if f.precision >= 0.9]
    if good:
        return max(good)[1]
    return max((2 * f.recall * f.precision / (f.recall + f.precision) if f.found else 0.0, t) for t, f in scored)[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trained", type=Path, required=True, help="the training's output folder")
    parser.add_argument("--out", type=Path, required=True, help="where the shipped files go")
    parser.add_argument("--tuning-frames", type=int, default=60)
    parser.add_argument("--frames", type=int, default=150, help="held-out frames the figures are reported on")
    args = parser.parse_args(argv)
    description = read_model_description(args.trained / f"{NAME}.toml")
    model = (args.trained / f"{NAME}.onnx").read_bytes()
    detector = OnnxDetector(replace(description, score_threshold=min(THRESHOLDS)), model)
    scale = Letterbox.fit(SIZE, (description.input_width, description.input_height)).scale_x
    threshold = _choose(_runs(detector, range(TUNING_SEEDS, TUNING_SEEDS + args.tuning_frames)), scale)
    figures = _figures(_runs(detector, range(REPORTED_SEEDS, REPORTED_SEEDS + args.frames)), threshold, scale)
    summary = figures.summary(KEYPOINTS)
    print(json.dumps({"threshold": threshold, **summary}, indent=1), flush=True)
    sigma = [round(figures.sigma(k), 3) for k in KEYPOINTS]  # (too few found keypoints stop here, nothing written)
    median = [round(figures.median_error(k), 3) for k in KEYPOINTS]
    args.out.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(args.trained / f"{NAME}.onnx", args.out / f"{NAME}.onnx")
    record = json.loads((args.trained / "training.json").read_text())
    record["held_out"] = {"frames": args.frames, "size": SIZE, "seeds": f"{REPORTED_SEEDS}..", "threshold": threshold,
                          "tuning_frames": args.tuning_frames, **summary}
    (args.out / "training.json").write_text(json.dumps(record, indent=1))
    text = (args.trained / f"{NAME}.toml").read_text()
    text = text.replace(f"score_threshold = {description.score_threshold}", f"score_threshold = {threshold}")
    text += ("\n[validation]  # measured on held-out rendered frames (640 x 480, every housing kind), input pixels\n"
             f"keypoint_sigma = {sigma}\nmedian_error = {median}\nrecall = {round(figures.recall, 3)}\n"
             f"precision = {round(figures.precision, 3)}\n"
             f'source = "{args.frames} held-out rendered frames, seeds {REPORTED_SEEDS}.., '
             f'{figures.found + figures.missed} fish to find"\n')
    (args.out / f"{NAME}.toml").write_text(text)
    read_model_description(args.out / f"{NAME}.toml")  # the written file reads back
    print(f"wrote {args.out}", flush=True)
    return 0 if np.isfinite(figures.recall) else 1


if __name__ == "__main__":
    sys.exit(main())
