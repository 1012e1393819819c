"""Measure how alike a detection model errs on one fish from frame to frame, on rendered survey clips with
truth, and write the ``[frame_correlation]`` table a fish's lengths joined over frames are combined with
(docs/detection.md, "A fish over several frames").

A model points at a fish on every frame on its own, but it sees much the same fish each time (the same fin
shape, colour and seabed), so its errors on one fish repeat in part. Combined as independent instants, the
joined length's σ would shrink like 1/√k while its error does not; combined as one error carried along (as
tracked instants are), the σ never shrinks and is too cautious. The correlation ρ between two frames' length
errors of one fish says how much is shared (:func:`usvips.core.measurements.instants.combine_figure`).

Each clip (:func:`usvips.core.synth.stereo_survey.survey_clip`, seeds the caller chooses: never the
acceptance test's nor the bench's) is run as ``usvips detect`` runs it and scored as the acceptance scores it
(:func:`usvips.app.detection_acceptance.measure_acceptance`): every proposal with a length that is one true
fish in both images gives its normalised error (length − truth) / σ, σ its own (the clips' calibrations are
exact, so σ is the pointing part alone). ρ is estimated from the fish seen on two frames or more
(:func:`usvips.core.measurements.instants.frame_correlation`, pooled moments, jackknife uncertainty). Run::

    python -m usvips.training.frame_correlation --model resources/models/fish-centre-pose.toml \\
        --seeds 61000000 120 --out /tmp/fish-with-frame-correlation.toml

The output is the description with the table added (the model file beside it is not copied: put the table
into the shipped description); it never writes over its input and is written whole or not at all.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import defaultdict
from collections.abc import Callable, Sequence
from pathlib import Path

from usvips.app.detection_acceptance import AcceptanceFigures, measure_acceptance
from usvips.app.detection_model import load_model
from usvips.core.errors import UsvipsError
from usvips.core.measurements.instants import FrameCorrelation, frame_correlation
from usvips.io.atomic import write_text_atomic


def fish_errors(figures: AcceptanceFigures) -> list[list[float]]:
    """The normalised length errors of each fish (clip, fish) seen, in the order of the run."""
    grouped: dict[tuple[int, int], list[float]] = defaultdict(list)
    for fish, z in zip(figures.fish, figures.single, strict=True):
        grouped[fish].append(z)
    return list(grouped.values())


def measure_frame_correlation(model_path: Path, seeds: Sequence[int], frames: int = 4,
                              progress: Callable[[str], None] | None = None) -> FrameCorrelation:
    """ρ of the model described at ``model_path`` over the clips of ``seeds`` (``frames`` frames each)."""
    model = load_model(model_path)
    with tempfile.TemporaryDirectory(prefix="usvips-frame-correlation-") as folder:
        figures = measure_acceptance(model, seeds, Path(folder), frames=frames, progress=progress)
    return frame_correlation(fish_errors(figures))


def frame_correlation_table(correlation: FrameCorrelation, basis: str) -> str:
    """The ``[frame_correlation]`` TOML table of ``correlation``, measured on ``basis`` (one phrase)."""
    bound = "; the estimate lay beyond its bound" if correlation.bound else ""
    return ("\n[frame_correlation]  # measured by usvips.training.frame_correlation\n"
            f"length = {correlation.value:.4f}  # ± {correlation.uncertainty:.4f} (jackknife over the fish){bound}\n"
            f"basis = {json.dumps(basis)}\n")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m usvips.training.frame_correlation",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", required=True, help="the model's description file (.toml)")
    parser.add_argument("--seeds", nargs=2, type=int, metavar=("FIRST", "COUNT"), required=True,
                        help="the clips' seeds: FIRST, FIRST+1, ... (never the acceptance test's or the bench's)")
    parser.add_argument("--out", required=True, help="the description with [frame_correlation] added (a new file)")
    parser.add_argument("--frames", type=int, default=4, help="frames per clip (default 4)")
    args = parser.parse_args(argv)
    try:
        source, out = Path(args.model), Path(args.out)
        if out.resolve() == source.resolve():
            raise UsvipsError(f"{out}: would write over the model's description; name a new file")
        try:
            text = source.read_text(encoding="utf-8")
        except OSError as error:
            raise UsvipsError(f"{source}: cannot be read ({error.strerror or error})") from None
        if "[frame_correlation]" in text:
            raise UsvipsError(f"{source}: already has a [frame_correlation] table; remove it first")
        first, count = args.seeds
        if count < 1:
            raise UsvipsError(f"--seeds: COUNT must be >= 1, got {count}")
        if args.frames < 2:
            raise UsvipsError(f"--frames: a fish must be seen on 2 frames or more, got {args.frames}")
        correlation = measure_frame_correlation(source, range(first, first + count), args.frames,
                                                progress=lambda line: print(line, file=sys.stderr, flush=True))
        basis = (f"{correlation.objects} fish seen on 2-{args.frames} frames ({correlation.instants} lengths) of "
                 f"{count} rendered stereo survey clips of 640 x 480, seeds {first}..{first + count - 1}")
        write_text_atomic(out, text.rstrip("\n") + "\n" + frame_correlation_table(correlation, basis))
    except UsvipsError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(json.dumps({"frame_correlation": correlation.value, "uncertainty": correlation.uncertainty,
                      "fish": correlation.objects, "lengths": correlation.instants, "bound": correlation.bound}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
