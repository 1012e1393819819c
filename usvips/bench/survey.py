"""Benchmarks of measuring a survey: combining an object's instants, the QA of a survey's objects.

The QA row times :func:`usvips.app.quality.check` over objects whose figures are already computed (the
window's figure cache holds them; computing figures is timed by the figure rows of other areas)."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from usvips.app.quality import Checked, Place, check, species_maxima
from usvips.bench import best_time
from usvips.core.measurements import measure
from usvips.core.measurements.instants import combine_figure
from usvips.core.observation_record import ObservationRecord, Species

#: absolute targets (s) of the issue: 20 instants combined, per object
COMBINE_TARGET_S = 0.020
#: the QA of a survey of 10,000 objects (s)
QA_TARGET_S = 0.5
QA_OBJECTS = 10_000


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

    species = [Species("Sparidae", "Pagrus", "auratus", max_length_m=0.4), Species("Labridae", "Achoerodus", "gouldii")]
    records = [ObservationRecord.of(s) for s in species] + [None]
    measured = []
    for k in range(50):  # 50 distinct measurements, some breaking rules, shared by the survey's objects
        ends = np.array([[0.0, 0.0, -2.0 - 0.2 * k], [0.2 + 0.01 * k, 0.0, -2.0 - 0.2 * k]])
        measured.append(measure("length", ends, np.eye(6) * (1e-6 * (1 + k)), ray_rms_m=0.001 * k, range_m=0.2 * k))
    n = QA_OBJECTS if scale >= 1 else max(100, int(QA_OBJECTS * scale))
    survey = [Checked(str(i), "length", measured[i % 50], records[i % 3], Place(f"pair p{i // 100}", f"p{i // 100}"))
              for i in range(n)]
    maxima = species_maxima(species)

    def qa() -> object:
        return check(survey, species=maxima)

    def bare() -> object:
        return [(c.measurement.ray_rms_m, c.measurement.range_m, c.measurement.main.relative_precision)
                for c in survey]

    qa()
    yield _absolute(f"QA of a survey of {n} objects (ray RMS, precision, range, species maximum)", n,
                    best_time(qa, 3), best_time(bare, 3), "reading each object's RMS, range and precision",
                    QA_TARGET_S)
