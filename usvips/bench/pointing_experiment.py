"""The pointing experiment of docs/pointing.md (``usvips bench --only pointing_experiment``): how well the
image itself defines each kind of point a person clicks — a target's centre, a fish's snout, its tail
fork — in clear, hazy and turbid water, rendered by the project's ray tracer
(:func:`usvips.core.pointing_test.how_well_defined`, over ``SCENES`` random scenes per cell, seeded).

Each row: the Cramér–Rao bound of locating the point's neighbourhood under the sensor noise and the
spread the least-squares locator reaches (a LOWER bound of any pointing: no person is told here), and on a
fish the offset of the visible edge from the true point along the body (mean and SD over scenes: what a
person clicking the visible tip or notch is off by, systematically for one scene, randomly over fish).
No person clicked anything: the rows measure the images, not a hand.
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import numpy as np

from usvips.core.pointing_test import CONDITIONS, FEATURES, how_well_defined

#: scenes per (feature, condition) at scale 1, and noise draws per scene
SCENES, DRAWS = 8, 20


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    scenes = max(2, int(round(SCENES * min(scale, 1.0))))
    for feature in FEATURES:
        for condition in CONDITIONS:
            start = time.perf_counter()
            found = [how_well_defined(feature, condition, seed, DRAWS) for seed in range(scenes)]
            elapsed = time.perf_counter() - start
            offsets = np.array([f["edge_offset_px"] for f in found])
            row = {"name": f"pointing experiment: {feature}, {condition.name} water", "n": scenes,
                   "ours_s": round(elapsed, 3), "baseline": None, "baseline_s": None, "ratio": None, "target": None,
                   "met": None, "blur_px": condition.blur_px, "attenuation_per_m": condition.attenuation,
                   "noise_grey": condition.noise,
                   "crlb_px": round(float(np.mean([f["crlb_px"] for f in found])), 4),
                   "located_px": round(float(np.sqrt(np.mean([f["located_px"] ** 2 for f in found]))), 4)}
            if np.all(np.isfinite(offsets)):
                row.update(edge_offset_mean_px=round(float(offsets.mean()), 3),
                           edge_offset_sd_px=round(float(offsets.std(ddof=1)), 3))
            yield row
