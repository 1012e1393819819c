"""The calibration's part of a point's covariance: the batched differences (stepped cameras kept per
calibration, pose steps moving the traced rays rigidly, one intersection for all steps) against the plain
reference loop (rebuild the cameras, retrace, re-intersect per parameter), over random rigs of every water
housing kind, random covariances, noisy picks, both frames and a further station.

Tolerance: an entry of the covariance within 1e-4 of sqrt(C_ii C_jj). Both paths take the same forward
differences; they differ only in rounding (a rigid motion of the traced rays instead of a new trace, the
order of the arithmetic). A difference of points computed to ε|X| over a step h carries ε|X|κ/h of
rounding (κ the intersection's conditioning, about range / baseline): with h = 1e-7 rad, |X| up to 100 m
(the ROV sample's object frame) and κ ≈ 10 that is ~2e-6 of a derivative of O(1) m/rad, so 1e-4 stands
well above the reference's own noise while a missing, misplaced or wrongly scaled column is an error of
order one.
"""

from __future__ import annotations

import numpy as np
import pytest

from usvips.core import housing as housings
from usvips.core.calibration import uncertainty
from usvips.core.calibration.model import stereo_cameras
from usvips.core.calibration.parameter_names import exterior_of
from usvips.core.camera import EXTERIOR_PARAMETERS, Exterior
from usvips.core.interior import INTERIOR_PARAMETERS
from usvips.core.rig import RelativeOrientation, relative_orientation, right_exterior
from usvips.core.stereo_calibration import ParameterEstimate, StereoCalibration
from usvips.io.calibration_file import load_calibration
from usvips.locations import sample_project

STATIONS = ("s0", "s1")
SIZE = (1280, 960)
#: prior-like sigmas of the random covariances, per symbol (pixels, metres, radians, dimensionless)
SIGMAS = {"f": 1.0, "xp": 0.8, "yp": 0.8, "sy": 1e-4, "k1": 2e-3, "k2": 2e-3, "k3": 1e-3, "p1": 2e-4, "p2": 2e-4,
          "X0": 2e-3, "Y0": 2e-3, "Z0": 2e-3, "omega": 1e-3, "phi": 1e-3, "kappa": 1e-3, "X": 1e-3}


def _symbol(name: str) -> str:
    return name.split("@")[0].rsplit("_", 1)[0] if "_" in name.split("@")[0] else name.split("@")[0]


def _random_values(rng: np.random.Generator, kind: str) -> dict[str, float]:
    values = {}
    for side, f in (("l", rng.uniform(900, 1300)), ("r", rng.uniform(900, 1300))):
        interior = {"f": f, "xp": 640 + rng.normal(0, 15), "yp": 480 + rng.normal(0, 15),
                    "sy": 1 + rng.normal(0, 0.01), "k1": rng.normal(-0.08, 0.03), "k2": rng.normal(0, 0.02),
                    "p1": rng.normal(0, 1e-3), "p2": rng.normal(0, 1e-3), "k3": rng.normal(0, 0.01)}
        values.update({f"{p}_{side}": interior[p] for p in INTERIOR_PARAMETERS})
    left = Exterior(rng.uniform(0.4, 0.8), rng.uniform(0.5, 0.9), rng.uniform(2.4, 2.9), *rng.normal(0, 0.04, 3))
    relative = RelativeOrientation(rng.uniform(0.3, 0.5), rng.normal(0, 0.01), rng.normal(0, 0.01),
                                   rng.normal(0, 0.01), rng.uniform(-0.15, -0.05), rng.normal(0, 0.01))
    further = Exterior(rng.uniform(0.2, 0.6), rng.uniform(0.4, 0.8), rng.uniform(2.5, 3.0), *rng.normal(0, 0.04, 3))
    for suffix, pose in (("_l", left), ("_r", right_exterior(left, relative)), ("_l@s1", further)):
        values.update({f"{p}{suffix}": getattr(pose, p) for p in EXTERIOR_PARAMETERS})
    cls = housings.kind(kind)
    for name in cls.calibration_names:
        spec = cls.spec(_symbol(name))
        value = spec.start + (0.3 * spec.sigma * rng.normal() if spec.sigma else 0.0)
        if spec.lower is not None:
            value = max(value, spec.lower + 0.5 * abs(spec.start - spec.lower))
        values[name] = value
    values["X@T1"] = 0.3  # a control coordinate moves no camera: its column is zero on both paths
    return values


def _random_calibration(rng: np.random.Generator, kind: str) -> StereoCalibration:
    values = _random_values(rng, kind)
    left, right = stereo_cameras(kind, values, STATIONS, STATIONS[0], SIZE)
    poses = (left.exterior, exterior_of(values, "l", "s1"))
    names = tuple(name for name in values if not name.startswith("k3"))
    sigmas = np.array([SIGMAS.get(_symbol(n)) or housings.kind(kind).spec(_symbol(n)).sigma or 1e-3 for n in names])
    mixing = rng.normal(size=(len(names), len(names)))
    correlated = mixing @ mixing.T / len(names) + np.eye(len(names))
    scale = sigmas / np.sqrt(np.diag(correlated))
    covariance = correlated * np.outer(scale, scale)
    estimates = {name: ParameterEstimate(value, None, "free") for name, value in values.items()}
    return StereoCalibration(left, right, STATIONS, poses, relative_orientation(left.exterior, right.exterior),
                             "water", 0.4, estimates, (names, covariance))


def _noisy_picks(rng: np.random.Generator, calibration: StereoCalibration, station: int, frame: str, n: int):
    rig = calibration.rig(station, frame)
    left = np.column_stack([rng.uniform(80, 1200, 4 * n), rng.uniform(80, 880, 4 * n)])
    bundle = rig.left.rays(left)
    points = bundle.origins + rng.uniform(1.0, 4.0, (4 * n, 1)) * bundle.directions
    right = rig.right.project(points)
    inside = bundle.ok & right.ok & np.all((right.pixels > 10) & (right.pixels < [1270, 950]), axis=1)
    index = np.flatnonzero(inside)[:n]
    assert index.size == n
    return (left[index] + rng.normal(0, 0.5, (n, 2)), right.pixels[index] + rng.normal(0, 0.5, (n, 2)))


def _reference_covariance(calibration, left, right, station, frame) -> np.ndarray:
    derivatives = uncertainty.reference_derivatives(calibration, left, right, station, frame)
    result, _ = uncertainty.joint_covariance(calibration, left, right, station, frame)
    n = len(left)
    full = np.zeros((3 * n, 3 * n))
    for i in range(n):
        full[3 * i:3 * i + 3, 3 * i:3 * i + 3] = result.covariance[i]
    flat = derivatives.reshape(len(derivatives), 3 * n)
    return full + flat.T @ np.asarray(calibration.covariance[1]) @ flat


def _assert_close(fast: np.ndarray, reference: np.ndarray) -> None:
    scale = np.sqrt(np.outer(np.diag(reference), np.diag(reference)))
    assert np.all(np.diag(reference) > 0)
    worst = float(np.max(np.abs(fast - reference) / scale))
    assert worst < 1e-4, worst


@pytest.mark.parametrize("kind", housings.water_names())
def test_batched_differences_give_the_reference_covariance_over_random_rigs(kind):
    rng = np.random.default_rng(sum(map(ord, kind)))
    for _ in range(4):
        calibration = _random_calibration(rng, kind)
        for station, frame in ((0, "object"), (1, "object"), (0, "rig")):
            left, right = _noisy_picks(rng, calibration, station, frame, 3)
            result, fast = uncertainty.joint_covariance(calibration, left, right, station, frame)
            assert result.ok.all()
            reference = _reference_covariance(calibration, left, right, station, frame)
            _assert_close(fast, reference)
            # the calibration's part is there: it is not the pointing part alone
            pointing = uncertainty.intersect_with_calibration(calibration, left, right, station, frame, False)
            assert np.max(np.abs(fast[:3, :3] - pointing.covariance[0])) > 1e-3 * np.abs(pointing.covariance[0]).max()


def test_the_rov_sample_in_its_object_frame_and_in_batches_of_a_few_rows(monkeypatch):
    calibration = load_calibration(sample_project("rov_flatport") / "calibration.json")
    left = np.array([[340.8, 145.2], [537.6, 119.8], [300.0, 300.0]])
    right = np.array([[59.4, 142.1], [256.0, 124.9], [20.0, 296.0]])
    for station, frame in ((0, "object"), (1, "object"), (0, "rig")):
        whole = uncertainty.joint_covariance(calibration, left, right, station, frame)[1]
        _assert_close(whole, _reference_covariance(calibration, left, right, station, frame))
        for rows in (7, 3):  # two parameters a batch (with the unstepped rows), then one (against the result)
            monkeypatch.setattr(uncertainty, "BATCH_ROWS", rows)
            monkeypatch.setattr(uncertainty, "_KEPT_ROWS", {})  # nothing kept from the call before
            split = uncertainty.joint_covariance(calibration, left, right, station, frame)[1]
            monkeypatch.undo()
            _assert_close(split, whole)


def test_stepped_cameras_are_kept_per_calibration_and_station():
    rng = np.random.default_rng(7)
    one, other = _random_calibration(rng, "flat-port"), _random_calibration(rng, "flat-port")
    kept = uncertainty.stepped_cameras(one, 0, "object")
    assert uncertainty.stepped_cameras(one, "s0", "object") is kept
    assert uncertainty.stepped_cameras(one, 1, "object") is not kept
    assert uncertainty.stepped_cameras(other, 0, "object") is not kept
    # a pose step of the first station moves only that pose (rigidly, no retrace) in the object frame
    names = one.covariance[0]
    moved = {names[c.index]: c.moved for c in kept}
    assert moved["omega_l"] == (uncertainty.MAPPED, uncertainty.UNMOVED)
    # the principal distance reads the same lens at other pixels; a distortion coefficient needs a new trace
    assert moved["f_r"] == (uncertainty.UNMOVED, uncertainty.MAPPED)
    assert moved["k1_l"] == (uncertainty.RETRACE, uncertainty.UNMOVED)
    assert "X@T1" not in moved and "X0_l@s1" not in moved


def test_a_vertex_picked_alone_serves_the_object_stored_from_it(monkeypatch):
    rng = np.random.default_rng(11)
    calibration = _random_calibration(rng, "flat-port")
    left, right = _noisy_picks(rng, calibration, 0, "rig", 2)
    fresh = uncertainty.joint_covariance(calibration, left, right, 0, "rig")[1]
    monkeypatch.setattr(uncertainty, "_KEPT_ROWS", {})
    for i in range(2):  # the picks, one vertex at a time
        uncertainty.joint_covariance(calibration, left[i:i + 1], right[i:i + 1], 0, "rig")

    def no_steps(*_):
        raise AssertionError("the stepped rays were computed again")

    monkeypatch.setattr(uncertainty, "_batched_derivatives", no_steps)
    kept = uncertainty.joint_covariance(calibration, left, right, 0, "rig")[1]
    # each row's derivatives depend on its own pixels only: the numbers computed together, but for the
    # rounding of the undistortion's Newton iterations (run until every row of a call converged) over a step
    scale = np.sqrt(np.outer(np.diag(fresh), np.diag(fresh)))
    assert np.max(np.abs(kept - fresh) / scale) < 1e-6
    assert np.abs(kept[:3, 3:]).max() > 0  # the calibration's part correlates the two vertices
    # other pixels, another calibration or another frame are not served from what was kept
    for args in ((calibration, left + 0.01, right, 0, "rig"), (_random_calibration(rng, "flat-port"), left, right, 0,
                                                                  "rig"), (calibration, left, right, 0, "object")):
        with pytest.raises(AssertionError, match="computed again"):
            uncertainty.joint_covariance(*args)


def test_without_a_parameter_covariance_only_the_pointing_part():
    from dataclasses import replace

    rng = np.random.default_rng(5)
    calibration = replace(_random_calibration(rng, "flat-port"), covariance=None)
    left, right = _noisy_picks(rng, calibration, 0, "rig", 2)
    assert uncertainty.stepped_cameras(calibration, 0, "rig") == ()
    result, full = uncertainty.joint_covariance(calibration, left, right, 0, "rig")
    pointing = uncertainty.intersect_with_calibration(calibration, left, right, 0, "rig", False)
    assert np.array_equal(full[:3, :3], pointing.covariance[0]) and np.all(full[:3, 3:] == 0)
