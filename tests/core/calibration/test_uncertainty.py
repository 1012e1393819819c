"""The calibration's part of a point's covariance: the derivatives of the intersected points by the
calibration's parameters (implicit-function theorem on the weighted intersection, poses and interiors in
closed form, housings by central differences of the traced rays) against careful central differences of
the whole chain (cameras rebuilt at θ ± h, pixels retraced, points re-intersected), over random rigs of
every housing kind, both frames and a further station.

Tolerances. On consistent pixels (projected from a point: every ray passes through it) the two agree to
the central differences' own error: a difference of points computed to ε|X| (the undistortion's Newton
tolerance, ~1e-13 relative) over 2h, with h chosen per parameter so that this and the O(h²) truncation stay
near 1e-7 of a column; a housing column, differenced with the model's step of 1e-6, carries ~1e-6. The test
allows 5e-6 of each column's largest entry (measured: at most 1.4e-6); a wrong, missing or wrongly scaled
column is an error of order one. On noisy picks the derivative is the first-order one (as the pointing
covariance is): the terms in the rays' residual misses are left out, which the difference of two noisy
intersections keeps (~10 % of a column at 0.5 px of noise on nearly parallel rays, where the rays' skew
moves the closest approach along them). There the plain reference loop (cameras rebuilt at θ ± h, pixels
retraced, the rays' points at the intersected point's depth differenced and moved through the weighted
intersection's normal equations) gives the same covariance to 1e-4 of sqrt(C_ii C_jj): it checks the closed
forms of the ray motions (rigid, pixel shift) against retraced rays.
"""

from __future__ import annotations

import numpy as np
import pytest

from usvips.core import housing as housings
from usvips.core import kernels
from usvips.core.calibration import point_derivatives, uncertainty
from usvips.core.calibration.model import stereo_cameras
from usvips.core.calibration.parameter_names import exterior_of
from usvips.core.camera import EXTERIOR_PARAMETERS, Exterior
from usvips.core.interior import INTERIOR_PARAMETERS
from usvips.core.intersection import intersect
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


def _assert_close(fast: np.ndarray, reference: np.ndarray, tolerance: float = 1e-4) -> None:
    scale = np.sqrt(np.outer(np.diag(reference), np.diag(reference)))
    assert np.all(np.diag(reference) > 0)
    worst = float(np.max(np.abs(fast - reference) / scale))
    assert worst < tolerance, worst


#: steps of the careful central differences (per symbol; 1e-5 otherwise): large enough that the points'
#: rounding over 2h stays near 1e-7 of a column, small enough that the O(h²) truncation does too
CENTRAL_STEPS = {"f": 1e-2, "xp": 1e-2, "yp": 1e-2, "sy": 1e-5, "X0": 1e-5, "Y0": 1e-5, "Z0": 1e-5}


def _consistent_picks(rng: np.random.Generator, calibration: StereoCalibration, station: int, frame: str, n: int):
    """Pixels of n random points 1-4 m in front of the rig, projected into both cameras (no noise)."""
    rig = calibration.rig(station, frame)
    left = np.column_stack([rng.uniform(80, 1200, 4 * n), rng.uniform(80, 880, 4 * n)])
    bundle = rig.left.rays(left)
    points = bundle.origins + rng.uniform(1.0, 4.0, (4 * n, 1)) * bundle.directions
    seen = [camera.project(points) for camera in rig.cameras]
    inside = bundle.ok & seen[0].ok & seen[1].ok & np.all((seen[1].pixels > 10) & (seen[1].pixels < [1270, 950]),
                                                          axis=1)
    index = np.flatnonzero(inside)[:n]
    assert index.size == n
    return seen[0].pixels[index], seen[1].pixels[index]


def _central_differences(calibration, left, right, station, frame, sigma_px) -> np.ndarray:
    """∂point/∂parameter (P, N, 3) by central differences: cameras rebuilt at θ ± h, pixels retraced, points
    re-intersected."""
    names = calibration.covariance[0]
    values = {name: p.value for name, p in calibration.parameters.items()}
    out = np.zeros((len(names), len(left), 3))
    for j, name in enumerate(names):
        step = CENTRAL_STEPS.get(_symbol(name), 1e-5)
        points = []
        for sign in (1, -1):
            moved = dict(values)
            moved[name] += sign * step
            cameras = stereo_cameras(calibration.left.housing.kind, moved, calibration.stations,
                                     calibration.stations[station], SIZE, frame)
            points.append(intersect([*cameras], [left, right], sigma_px).require_ok().points)
        out[j] = (points[0] - points[1]) / (2 * step)
    return out


@pytest.mark.parametrize("kind", housings.names())
def test_derivatives_agree_with_central_differences_over_random_rigs(kind):
    rng = np.random.default_rng(sum(map(ord, kind)) + 1)
    for _ in range(2):
        calibration = _random_calibration(rng, kind)
        for station, frame in ((0, "object"), (1, "object"), (0, "rig")):
            left, right = _consistent_picks(rng, calibration, station, frame, 6)
            sigma = rng.uniform(0.2, 1.0, (6, 2))
            result, derivatives, _ = uncertainty.intersection_derivatives(calibration, left, right, station, frame,
                                                                          sigma)
            assert result.ok.all()
            reference = _central_differences(calibration, left, right, station, frame, sigma)
            scale = np.abs(reference).max(axis=(1, 2))
            moved = scale > 0
            assert moved.sum() >= 20  # poses, interiors, housing: not only zero columns compared
            assert np.all(np.abs(derivatives[~moved]) == 0)
            worst = np.max(np.abs(derivatives - reference)[moved] / scale[moved, None, None])
            assert worst < 5e-6, worst


@pytest.mark.parametrize("kind", housings.names())
def test_the_compiled_pixel_motions_give_the_numpy_derivatives_over_random_rigs(kind, monkeypatch):
    """The pose and housing columns' pixel motions in one compiled pass (kernels.add_pose_shifts,
    add_housing_shift) against the numpy reference, from the same traced rays, on noisy picks of random rigs,
    both frames and a further station: the same derivatives but for the order of the sums."""
    calls = []
    for name in ("add_pose_shifts", "add_housing_shift"):
        compiled = getattr(kernels, name)
        monkeypatch.setattr(kernels, name, lambda *args, name=name, compiled=compiled: (calls.append(name),
                                                                                        compiled(*args)))
    rng = np.random.default_rng(sum(map(ord, kind)) + 5)
    calibration = _random_calibration(rng, kind)
    for station, frame in ((0, "object"), (1, "object"), (0, "rig")):
        left, right = _noisy_picks(rng, calibration, station, frame, 40)
        sigma = rng.uniform(0.2, 1.0, (40, 2))
        with kernels.mode("never"):
            _, traced, result, _ = uncertainty._prepared(calibration, left, right, station, frame, True, sigma)
            columns = uncertainty.stepped_cameras(calibration, station, frame)
            motions = [[(k, c.motions[side]) for k, c in enumerate(columns) if c.motions[side] is not None]
                       for side in range(2)]
            ideal = [uncertainty._ideal(t, motions[j]) for j, t in enumerate(traced)]
            moved = [point_derivatives.housing_rays(t, [m for _, m in motions[j]], ideal[j])
                     for j, t in enumerate(traced)]
        given = {}
        for mode in ("never", "always"):
            with kernels.mode(mode):
                given[mode] = point_derivatives.point_jacobian(traced, result.points, result.covariance,
                                                               1 / sigma ** 2, motions, len(columns), moved, ideal)
        reference, compiled = given["never"], given["always"]
        scale = np.abs(reference).max(axis=(0, 1))
        assert (scale > 0).sum() >= 20 and any(m.housings is not None for side in motions for _, m in side) == (
            kind != "air")
        assert np.max(np.abs(compiled - reference) / scale) < 1e-12
    assert set(calls) == ({"add_pose_shifts"} if kind == "air" else {"add_pose_shifts", "add_housing_shift"})


@pytest.mark.parametrize("kind", housings.water_names())
def test_noisy_picks_give_the_reference_loop_covariance_over_random_rigs(kind):
    rng = np.random.default_rng(sum(map(ord, kind)))
    for _ in range(2):
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
        for rows in (2, 1):  # the points in blocks of two, then one at a time
            monkeypatch.setattr(uncertainty, "BATCH_ROWS", rows)
            monkeypatch.setattr(uncertainty, "_KEPT_ROWS", {})  # nothing kept from the call before
            split = uncertainty.joint_covariance(calibration, left, right, station, frame)[1]
            monkeypatch.undo()
            _assert_close(split, whole, 1e-9)  # each point's derivatives depend on its own rays alone


def test_stepped_cameras_are_kept_per_calibration_and_station():
    rng = np.random.default_rng(7)
    one, other = _random_calibration(rng, "flat-port"), _random_calibration(rng, "flat-port")
    kept = uncertainty.stepped_cameras(one, 0, "object")
    assert uncertainty.stepped_cameras(one, "s0", "object") is kept
    assert uncertainty.stepped_cameras(one, 1, "object") is not kept
    assert uncertainty.stepped_cameras(other, 0, "object") is not kept
    # a pose step of the first station moves only that pose in the object frame; an interior parameter only
    # its camera's interior; a housing parameter only its camera's housing
    names = one.covariance[0]
    moved = {names[c.index]: c.motions for c in kept}

    def parts(motion):
        return None if motion is None else (motion.turn is not None, motion.interiors is not None,
                                            motion.housings is not None)

    assert [parts(m) for m in moved["omega_l"]] == [(True, False, False), None]
    assert [parts(m) for m in moved["f_r"]] == [None, (False, True, False)]
    assert [parts(m) for m in moved["k1_l"]] == [(False, True, False), None]
    assert [parts(m) for m in moved["d_l"]] == [(False, False, True), None]
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


def test_many_points_block_by_block_give_each_point_its_joint_covariance_block(monkeypatch):
    rng = np.random.default_rng(23)
    calibration = _random_calibration(rng, "dome-port")
    left, right = _noisy_picks(rng, calibration, 0, "object", 30)
    # a pair whose rays diverge (the point would lie behind the cameras) among them
    left[7], right[7] = [80.0, 480.0], [1200.0, 480.0]
    monkeypatch.setattr(uncertainty, "BATCH_ROWS", 8)  # blocks cut through the failed row
    streamed = uncertainty.intersect_with_calibration(calibration, left, right, 0, "object")
    assert not streamed.ok[7] and streamed.ok.sum() == 29
    result, joint = uncertainty.joint_covariance(calibration, left, right, 0, "object")
    for i in np.flatnonzero(result.ok):
        block = joint[3 * i:3 * i + 3, 3 * i:3 * i + 3]
        assert np.allclose(streamed.covariance[i], block, rtol=1e-10, atol=1e-12 * np.abs(block).max())
    assert np.all(streamed.covariance[7] == 0)
