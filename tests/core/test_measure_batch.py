"""Many objects measured at once (:func:`measure_picks_many`) are measured exactly as one at a time by the
one figure function's path from picks (:func:`measure_picks`): values, σ and their breakdown, covariance,
ray RMS and range; a failing object is its own error and does not stop the others."""

import numpy as np

from usvips.bench.scaling import CALIBRATION
from usvips.core.errors import DegenerateGeometryError, UsvipsError
from usvips.core.measurements import measure_picks
from usvips.core.measurements.batch import measure_picks_many
from usvips.io.calibration_file import load_calibration


def test_many_objects_are_measured_as_one_at_a_time():
    calibration = load_calibration(CALIBRATION)
    rig = calibration.rig(0, "rig")
    rng = np.random.default_rng(5)
    kinds, lefts, rights, sigmas = [], [], [], []
    while len(kinds) < 12:
        n = 2 if len(kinds) % 3 else 4
        ray = rig.left.rays(rng.uniform([200, 200], [1000, 700], (1, 2)))
        points = ray.origins[0] + rng.uniform(1.5, 3.0) * ray.directions[0] + rng.normal(0, 0.1, (n, 3))
        left, right = rig.left.project(points), rig.right.project(points)
        if not (left.ok.all() and right.ok.all()):
            continue
        kinds.append("length" if n == 2 else "polygon")
        lefts.append(left.pixels + rng.normal(0, 0.3, (n, 2)))
        rights.append(right.pixels + rng.normal(0, 0.3, (n, 2)))
        sigmas.append(None if len(kinds) % 2 else rng.uniform(0.2, 1.0, (n, 2)))
    lefts.append(np.array([[1.0, 2.0], [np.nan, 3.0]]))  # not finite: its own error
    rights.append(np.array([[1.0, 2.0], [2.0, 3.0]]))
    kinds.append("length")
    sigmas.append(None)
    many = measure_picks_many(kinds, calibration, lefts, rights, 0, "rig", sigmas)
    assert isinstance(many[-1], DegenerateGeometryError)
    for kind, left, right, sigma, batch in zip(kinds[:-1], lefts, rights, sigmas, many, strict=False):
        one = measure_picks(kind, calibration, left, right, 0, "rig", pointing_sigma_px=sigma)
        assert not isinstance(batch, UsvipsError)
        assert batch.kind == one.kind and batch.marks == one.marks
        assert np.allclose(batch.points, one.points, rtol=0, atol=1e-12)
        # equal but for the rounding of the undistortion's Newton steps, which a forward difference magnifies
        assert np.allclose(batch.covariance, one.covariance, rtol=0, atol=1e-5 * np.abs(one.covariance).max())
        assert np.isclose(batch.ray_rms_m, one.ray_rms_m, rtol=1e-9)
        assert np.isclose(batch.range_m, one.range_m, rtol=1e-12)
        for a, b in zip(batch.figures, one.figures, strict=True):
            assert a.name == b.name and np.isclose(a.value, b.value, rtol=1e-12, atol=1e-12)
            assert np.isclose(a.sigma, b.sigma, rtol=1e-5) and np.isclose(a.sigma_pointing, b.sigma_pointing,
                                                                          rtol=1e-5)
