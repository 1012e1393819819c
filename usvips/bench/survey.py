"""Benchmarks of measuring a survey: combining an object's instants, the QA of a survey's objects."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from usvips.bench import best_time
from usvips.core.measurements.instants import combine_figure

#: absolute targets (s) of the issue: 20 instants combined, per object
COMBINE_TARGET_S = 0.020


def _absolute(name: str, n: int, ours: float, baseline: float, baseline_name: str, target_s: float) -> dict:
    return {"name": name, "n": n, "ours_s": round(ours, 6), "baseline": baseline_name,
            "baseline_s": round(baseline, 6), "ratio": round(ours / baseline, 2) if baseline > 0 else None,
            "target": None, "target_s": target_s, "met": bool(ours <= target_s)}


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    rng = np.random.default_rng(1)
    sigmas = rng.uniform(0.002, 0.008, 20)
    values = 0.4 + rng.normal(0, 0.01, 20) + rng.normal(0, sigmas)
    labels = [f"frame {i}" for i in range(20)]

    def ours() -> object:
        return combine_figure(values, sigmas, 0.002, labels=labels, calibrations=[1] * 20)

    def baseline() -> object:
        return np.average(values, weights=1 / sigmas ** 2)

    ours()  # warm scipy's lazy imports
    yield _absolute("combine 20 instants of a length (random effects, leave-one-out residuals)", 20,
                    best_time(ours, 20), best_time(baseline, 20), "numpy's weighted mean of the 20 values",
                    COMBINE_TARGET_S)
