"""Issue 35's acceptance row: the detection model (the project's shipped one, whichever it is) run end to end as
``usvips detect`` runs it — detection, stereo pairing through the housing, refinement along the curve, the
lengths and their σ, proposals joined into fish over a video — on rendered stereo survey clips with truth
(:mod:`usvips.app.detection_acceptance`: random rigs of every housing kind, seeds neither the training, the
shipping step nor the tests use), against the issue's targets: ≥ 90 % of the fish measured, ≥ 90 % of the
lengths within 2σ of the truth, a NEES of 0.7-1.5 and no proposal paired across two fish. Not a timing: the
row's ``met`` says whether every target is met, and its figures are the measurement.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from usvips.app.detection_acceptance import measure_acceptance
from usvips.app.detection_model import bundled_model_path, load_model

#: the clips' seeds (a range no other measurement of the model uses)
SEEDS = 50_000_000
#: clips at scale 1 (4 frames each, 640 × 480: about a minute of CPU)
CLIPS = 24


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    model = load_model(bundled_model_path())
    clips = max(6, int(round(CLIPS * scale)))
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        figures = measure_acceptance(model, range(SEEDS, SEEDS + clips), Path(folder))
    seconds = time.perf_counter() - start
    summary = figures.summary()
    yield {"name": f"issue 35 acceptance: model {model.tag} on {clips} rendered stereo survey clips "
                   "(measured, within 2 sigma, NEES, cross-fish pairs)",
           "n": summary["fish_to_measure"], "ours_s": round(seconds, 3), "baseline": None, "baseline_s": None,
           "ratio": None, "target": None, "target_s": None, **summary, "met": all(summary["met"].values()),
           "met_by_target": summary["met"]}
