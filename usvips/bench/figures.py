"""``usvips bench`` row of the figure path's cost: the figures of 10,000 fish lengths (what a survey's
object list computes when it opens), their vertices and joint covariance already intersected, with σ as the
figure path states it (first order plus the second-order part where it matters,
:mod:`usvips.core.measurements.figures`), against the same figures with first-order σ alone timed beside
it. The fish are picked with 0.5 px of noise through the bundled ``rov_flatport`` calibration (it has a
parameter covariance): four fifths 0.2-0.5 m long at 1.5-3.5 m (the σ check's survey), a fifth short and
far (0.1-0.2 m at 4-6 m). The row also gives the time of the whole path for the same picks
(``measure_picks_many``: intersection, covariance and figures), of which the figures are a small part."""

from __future__ import annotations

import time
from collections.abc import Iterator

import numpy as np

from usvips.bench import ratio_row
from usvips.bench.scaling import CALIBRATION
from usvips.core.measurements import Measurement
from usvips.core.measurements.batch import measure_picks_many
from usvips.core.measurements.figures import NEGLIGIBLE_SPREAD, figures_of
from usvips.core.measurements.kinds.length import Length
from usvips.io.calibration_file import load_calibration

OBJECTS = 10_000
#: the promise: the figures with their second-order part cost at most this many times those with first-order
#: σ alone (an eigen-decomposition of the 6 × 6 covariance and 18 more rows of the vectorised formula an
#: object: 0.1-0.2 ms, against the ~2 ms its intersection with the calibration's covariance costs)
TARGET_RATIO = 3.0


def picks(n: int, seed: int = 0):
    """The calibration and the picks (n of (2, 2) px per side) of n fish (the mix of the module's text)."""
    calibration = load_calibration(CALIBRATION)
    rig = calibration.rig(0, "rig")
    rng = np.random.default_rng(seed)
    left, right = [], []
    while len(left) < n:
        far = len(left) < n // 5
        ray = rig.left.rays(rng.uniform([150, 150], [1130, 810])[None])
        snout = ray.origins[0] + rng.uniform(*((4.0, 6.0) if far else (1.5, 3.5))) * ray.directions[0]
        direction = rng.normal(0, 1, 3) * [1.0, 1.0, 0.3]
        ends = np.array([snout, snout + rng.uniform(*((0.1, 0.2) if far else (0.2, 0.5)))
                         * direction / np.linalg.norm(direction)])
        seen_left, seen_right = rig.left.project(ends), rig.right.project(ends)
        if seen_left.ok.all() and seen_right.ok.all():
            left.append(seen_left.pixels + rng.normal(0, 0.5, (2, 2)))
            right.append(seen_right.pixels + rng.normal(0, 0.5, (2, 2)))
    return calibration, left, right


def measured(calibration, left: list, right: list) -> list[Measurement]:
    n = len(left)
    return [m for m in measure_picks_many(["length"] * n, calibration, left, right, 0, "rig", [0.5] * n)
            if isinstance(m, Measurement)]


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    n = max(100, int(OBJECTS * min(scale, 1.0)))
    calibration, left, right = picks(n)
    start = time.perf_counter()
    fish = measured(calibration, left, right)
    whole_s = time.perf_counter() - start

    def figures(nonlinear: bool) -> object:
        return [figures_of(Length.values, Length.figure_names, m.points, m.covariance, many=Length.values_many,
                           nonlinear=nonlinear) for m in fish]

    taken = np.mean([np.trace(m.covariance) >= NEGLIGIBLE_SPREAD ** 2 * np.sum((m.points - m.points.mean(axis=0)) ** 2)
                     / 2 for m in fish])
    yield ratio_row(f"figures of {len(fish):,} fish lengths, σ with its second-order part where it matters",
                    len(fish), lambda: figures(True), lambda: figures(False),
                    "the same figures, first-order σ alone", TARGET_RATIO, repeats=2,
                    second_order_share=round(float(taken), 3), whole_path_s=round(whole_s, 3))
