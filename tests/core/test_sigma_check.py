"""The σ check (:mod:`usvips.core.sigma_check`) on a calibrated rig with a parameter covariance: lengths
stated with the σ the one figure function gives hold (NEES inside the band) when the picks' true pointing
σ is the one they were stated with, and are called too small when it is three times larger; the check
is seeded (the same figures twice) and stops when cancelled."""

import numpy as np
import pytest

from tests.core.calibration_scenes import control_frame, joined, observe, rig_at
from usvips.core.calibration import CalibrationOptions, calibrate_air
from usvips.core.errors import InvalidParameterError
from usvips.core.measurements import measure_picks
from usvips.core.sigma_check import CheckedObject, CheckGeometry, SigmaCheckCancelled, check_sigmas


@pytest.fixture(scope="module")
def calibrated():
    control = control_frame()
    pairs = [observe(rig_at(k), control.xyz, control.ids, f"p{k}", seed=k) for k in range(2)]
    result = calibrate_air(control, joined(pairs), CalibrationOptions(sigma_px=0.5))
    return result.calibration


#: the picks' pointing σ the lengths are stated with (px)
POINTING = 0.4


def _objects(calibration, rng, count=60):
    rig = calibration.rig(0, "object")
    objects = []
    while len(objects) < count:
        a = np.array([rng.uniform(0.2, 1.2), rng.uniform(0.2, 1.2), rng.uniform(-0.6, 0.0)])
        b = a + rng.normal(0, 1, 3) * [0.2, 0.2, 0.05]
        points = np.array([a, b])
        left, right = rig.left.project(points), rig.right.project(points)
        # fish-sized (≥ 15 cm): a length of a few sigmas of depth has a nonlinear (upward-biased) error
        if not (left.ok.all() and right.ok.all()) or np.linalg.norm(b - a) < 0.15:
            continue
        m = measure_picks("length", calibration, left.pixels, right.pixels, 0, "object", pointing_sigma_px=POINTING)
        objects.append((m, points))
    return objects


def test_stated_sigmas_hold_when_the_pointing_is_what_they_were_stated_with(calibrated):
    rng = np.random.default_rng(1)
    pointing = POINTING
    measured = _objects(calibrated, rng)
    geometry = [CheckGeometry(calibrated, 0, "object")]

    def check(pointing, seed=0):
        objects = [CheckedObject(str(i), "length", m.points, m.main.sigma, 0, np.full((2, 2), pointing))
                   for i, (m, _) in enumerate(measured)]
        return check_sigmas(objects, geometry, replicas=30, seed=seed)

    honest = check(pointing)
    (row,) = honest.kinds
    print(f"pointing {pointing:.3f} px: NEES {row.nees:.2f} ({row.low:.2f}–{row.high:.2f})")
    assert row.kind == "length" and row.objects == 60 and row.replicas == 30
    # a little above 1: a depth error of ~6 mm a vertex biases a 15-40 cm length upwards (dz² / 2L), which
    # the first-order σ does not hold; the check is not linearised and sees it
    assert row.verdict == "hold" and 0.85 <= row.nees <= 1.3
    (understated,) = check(3 * pointing).kinds
    print(f"pointing 3×: NEES {understated.nees:.2f} ({understated.low:.2f}–{understated.high:.2f})")
    # 9 at first order where pointing dominates; more, as a depth error of ~2 cm a vertex biases a 20 cm
    # length upwards (dz² / 2L): the check is not linearised
    assert understated.verdict == "too small" and understated.low > 6.0
    assert check(pointing).kinds == honest.kinds  # seeded: the same figures again
    assert check(pointing, seed=1).kinds != honest.kinds


def test_the_calibration_part_is_drawn(calibrated):
    """Without the calibration's part in the stated σ (pointing only), the check sees the missing part: a
    larger NEES than with the whole σ for the same objects. The calibration's covariance is scaled by 25 so
    that its part is a fair share of the lengths' variance (as it is, ~1 %: too little to see)."""
    from dataclasses import replace

    from usvips.core.calibration.uncertainty import intersect_with_calibration
    from usvips.core.measurements import measure

    names, covariance = calibrated.covariance
    calibrated = replace(calibrated, covariance=(names, 25 * covariance))
    rng = np.random.default_rng(2)
    pointing_only, whole = [], []
    for i, (m, _) in enumerate(_objects(calibrated, rng, 40)):
        rig = calibrated.rig(0, "object")
        left, right = rig.left.project(m.points).pixels, rig.right.project(m.points).pixels
        pointing = intersect_with_calibration(calibrated, left, right, 0, "object", include_calibration=False,
                                              pointing_sigma_px=POINTING)
        stated = measure("length", pointing.points, pointing.covariance).main.sigma
        pointing_only.append(CheckedObject(str(i), "length", m.points, stated, 0, np.full((2, 2), POINTING)))
        whole.append(CheckedObject(str(i), "length", m.points, m.main.sigma, 0, np.full((2, 2), POINTING)))
    geometry = [CheckGeometry(calibrated, 0, "object")]
    (row,) = check_sigmas(pointing_only, geometry, replicas=30).kinds
    (full,) = check_sigmas(whole, geometry, replicas=30).kinds
    print(f"pointing-only σ: NEES {row.nees:.2f} ({row.low:.2f}–{row.high:.2f}); whole σ: NEES {full.nees:.2f}")
    assert row.low > 1.0 and row.nees > 1.3 * full.nees


def test_cancel_and_bad_input(calibrated):
    m, _ = _objects(calibrated, np.random.default_rng(3), 1)[0]
    one = [CheckedObject("7", "length", m.points, m.main.sigma, 0, np.full((2, 2), 0.3))]
    geometry = [CheckGeometry(calibrated, 0, "object")]
    with pytest.raises(SigmaCheckCancelled):
        check_sigmas(one, geometry, cancel=lambda: True)
    with pytest.raises(InvalidParameterError, match="replicas"):
        check_sigmas(one, geometry, replicas=1)
    with pytest.raises(InvalidParameterError, match="none to check"):
        check_sigmas([], geometry)
    with pytest.raises(InvalidParameterError, match="object 7: stated σ"):
        check_sigmas([CheckedObject("7", "length", m.points, 0.0, 0, np.full((2, 2), 0.3))], geometry)
