"""``usvips bench`` row of the σ check (issue 32): ``usvips project check --sigma`` of a 1,000-object
project (fish lengths measured with the bundled ``rov_flatport`` calibration, which has a parameter
covariance) must take ≤ 10 s, reading included; the baseline timed beside it is reading the same
project's figures (:func:`usvips.app.project_figures.measure_stored` of every object), what any report of
the project pays."""

from __future__ import annotations

import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from usvips.app.calibrations import store_calibration
from usvips.app.project_figures import measure_stored
from usvips.app.sigma_check import check_project_sigmas
from usvips.bench.scaling import CALIBRATION
from usvips.io.calibration_file import load_calibration
from usvips.store.opening import create_project, open_project
from usvips.store.records import Vertex

#: objects of the benchmark's project, and the promise (s)
OBJECTS = 1000
TARGET_S = 10.0


def build_survey(path: Path, objects: int = OBJECTS, seed: int = 0, pointing_px: float = 0.5,
                 ranges_m: tuple[float, float] = (1.5, 3.5), lengths_m: tuple[float, float] = (0.2, 0.5)) -> Path:
    """A project of ``objects`` fish lengths (``lengths_m``, their snouts ``ranges_m`` along a random ray of
    the left camera) picked with ``pointing_px`` of noise through the ``rov_flatport`` calibration, on one
    image pair ``dive``."""
    calibration = load_calibration(CALIBRATION)
    rig = calibration.rig(0, "rig")
    rng = np.random.default_rng(seed)
    rows = []
    with create_project(path) as project:
        project.add_pair("dive")
        calibration_id = store_calibration(project, "cal", calibration, ("dive",))
        while len(rows) < objects:
            pixel = rng.uniform([150, 150], [1130, 810])
            ray = rig.left.rays(pixel[None])
            snout = ray.origins[0] + rng.uniform(*ranges_m) * ray.directions[0]
            direction = rng.normal(0, 1, 3) * [1.0, 1.0, 0.3]
            fork = snout + rng.uniform(*lengths_m) * direction / np.linalg.norm(direction)
            ends = np.array([snout, fork])
            left, right = rig.left.project(ends), rig.right.project(ends)
            if not (left.ok.all() and right.ok.all()):
                continue
            picks = np.hstack([left.pixels, right.pixels]) + rng.normal(0, pointing_px, (2, 4))
            rows.append(("length", [Vertex(*map(float, p), calibration_id=calibration_id, pair="dive") for p in picks],
                         "", "", ""))
        project.add_objects(rows)
    return path


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    objects = max(50, int(OBJECTS * min(scale, 1.0)))
    with tempfile.TemporaryDirectory() as folder:
        path = build_survey(Path(folder) / "survey.usvips", objects)
        with open_project(path, read_only=True) as project:
            start = time.perf_counter()
            report = check_project_sigmas(project)
            ours = time.perf_counter() - start
            start = time.perf_counter()
            for stored in project.objects():
                measure_stored(project, stored)
            baseline = time.perf_counter() - start
    row = report.check.kinds[0]
    yield {"name": "sigma check (project check --sigma)", "n": objects, "ours_s": round(ours, 3),
           "baseline": "reading every object's figures", "baseline_s": round(baseline, 3),
           "ratio": round(ours / baseline, 2) if baseline > 0 else None, "target": None, "target_s": TARGET_S,
           "met": bool(ours <= TARGET_S), "replicas": report.check.replicas, "nees": round(row.nees, 3)}
