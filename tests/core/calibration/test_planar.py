"""The planar start: board views give both cameras' interior, every view's pose and the rig's relative
orientation with no 3-D spread; the calibration takes it automatically; degenerate sets are named."""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.board_scenes import board, observe_views, random_rig, random_views, view_pose
from usvips.core.calibration import CalibrationOptions, calibrate_air
from usvips.core.calibration.planar import (
    MIN_DEPTH_SPREAD,
    camera_matrix,
    depth_spread,
    exterior_from_opencv,
    exterior_to_opencv,
    planar_start,
    resect_views,
)
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import DegenerateGeometryError
from usvips.core.interior import Interior
from usvips.core.observations import StereoObservations


def test_our_pose_and_opencvs_project_alike():
    import cv2

    rng = np.random.default_rng(3)
    control = board()
    rig = random_rig(rng)
    for _ in range(10):
        pose = view_pose(control, rig, rng, rng.uniform(0.4, 0.9), rng.uniform(0, 50))
        rvec, tvec = exterior_to_opencv(pose)
        again = exterior_from_opencv(rvec, tvec)
        np.testing.assert_allclose(again.position, pose.position, atol=1e-12)
        np.testing.assert_allclose(again.rotation, pose.rotation, atol=1e-12)
        pinhole = Interior(rig.left.f, rig.left.xp, rig.left.yp, rig.left.sy)
        ours = Camera(pinhole, pose).project(control.xyz).pixels
        matrix, distortion = camera_matrix(pinhole)
        theirs = cv2.projectPoints(control.xyz, rvec, tvec, matrix, distortion)[0].reshape(-1, 2)
        np.testing.assert_allclose(ours, theirs, atol=1e-6)


@pytest.mark.parametrize("seed", range(5))
def test_the_planar_start_is_near_the_truth(seed):
    rng = np.random.default_rng(100 + seed)
    control = board(rng.integers(6, 11), rng.integers(4, 8), rng.uniform(0.02, 0.04))
    rig = random_rig(rng)
    poses = random_views(control, rig, rng, 12)
    start = planar_start(control, observe_views(control, rig, poses, rng, 0.3), rig.size)
    # no distortion and sy = 1 in the start: near, not at, the truth
    for truth, got in zip((rig.left, rig.right), start.interiors, strict=True):
        assert abs(got.f / truth.f - 1) < 0.05
        assert abs(got.xp - truth.xp) < 0.08 * truth.f and abs(got.yp - truth.yp) < 0.08 * truth.f
    # the principal point's error (no distortion yet) trades with the rig's angles: 0.1 rad, not a sign
    assert np.linalg.norm(start.relative.base - rig.relative.base) < 0.1 * np.linalg.norm(rig.relative.base)
    assert abs(start.relative.phi - rig.relative.phi) < 0.15
    for k, pose in enumerate(poses):
        assert np.linalg.norm(start.poses[(f"v{k}", "l")].position - pose.position) < 0.05 * np.linalg.norm(
            pose.position - control.xyz.mean(axis=0))


def test_resection_with_a_known_interior_finds_each_views_pose():
    rng = np.random.default_rng(7)
    control = board()
    rig = random_rig(rng)
    poses = random_views(control, rig, rng, 5)
    found = resect_views(control, observe_views(control, rig, poses, rng, 0.2), rig.left, "l")
    for k, pose in enumerate(poses):
        np.testing.assert_allclose(found[f"v{k}"].position, pose.position, atol=2e-3)


def test_a_board_calibrates_in_air_without_3d_spread():
    rng = np.random.default_rng(11)
    control = board()
    rig = random_rig(rng)
    observations = observe_views(control, rig, random_views(control, rig, rng, 10), rng, 0.3)
    result = calibrate_air(control, observations, CalibrationOptions(sigma_px=0.3, image_size=rig.size,
                                                                     control_exact=True))
    assert result.adjustment.converged
    assert 0.8 < result.calibration.sigma0_px / 0.3 < 1.2
    for truth, got, side in ((rig.left, result.calibration.left.interior, "l"),
                             (rig.right, result.calibration.right.interior, "r")):
        sigma = result.calibration.parameters[f"f_{side}"].sigma
        assert abs(got.f - truth.f) < 5 * sigma


def _fronto_parallel(rng, control, rig, count):
    return [view_pose(control, rig, rng, rng.uniform(0.4, 0.9), rng.uniform(0.0, 0.5)) for _ in range(count)]


def test_views_all_parallel_to_the_image_plane_are_named():
    rng = np.random.default_rng(5)
    control = board()
    rig = random_rig(rng)
    observations = observe_views(control, rig, _fronto_parallel(rng, control, rig, 8), rng, 0.3)
    with pytest.raises(DegenerateGeometryError, match="parallel to the image plane.*cannot be told apart"):
        planar_start(control, observations, rig.size)
    with pytest.raises(DegenerateGeometryError, match="parallel to the image plane"):
        calibrate_air(control, observations, CalibrationOptions(image_size=rig.size))
    # one tilted view among them is enough to tell them apart
    tilted = _fronto_parallel(rng, control, rig, 7) + [view_pose(control, rig, rng, 0.6, 35.0)]
    planar_start(control, observe_views(control, rig, tilted, rng, 0.3), rig.size)


def test_the_depth_spread_measures_tilt_whatever_the_focal_length():
    rng = np.random.default_rng(9)
    control = board()
    rig = random_rig(rng)
    for tilt, low, high in ((0.0, 0.0, MIN_DEPTH_SPREAD), (30.0, 0.05, 1.0)):
        pose = view_pose(control, rig, rng, 0.8, tilt)
        projection = rig.at(pose).left.project(control.xyz)
        assert projection.ok.sum() > 20
        assert low <= depth_spread(control.xyz[projection.ok, :2], projection.pixels[projection.ok]) <= high


def test_too_few_views_too_few_points_and_one_camera_points_are_named():
    rng = np.random.default_rng(13)
    control = board()
    rig = random_rig(rng)
    observations = observe_views(control, rig, random_views(control, rig, rng, 4), rng, 0.3)
    two = observations.take(np.flatnonzero([p in ("v0", "v1") for p in observations.pairs]))
    with pytest.raises(DegenerateGeometryError, match="coplanar.*only 2 view"):
        planar_start(control, two, rig.size)
    v2 = np.flatnonzero([p == "v2" for p in observations.pairs])
    keep = [i for i, p in enumerate(observations.pairs) if p != "v2" or i in v2[:4]]
    with pytest.raises(DegenerateGeometryError, match="view 'v2': only 4 target points"):
        planar_start(control, observations.take(np.array(keep)), rig.size)
    right = observations.right.copy()
    right[5] = np.nan
    one_camera = StereoObservations(observations.ids, observations.left, right, observations.pairs)
    with pytest.raises(DegenerateGeometryError, match=f"view 'v0': target point '{observations.ids[5]}' has no "
                       "right pixel \\(seen by one camera only\\)"):
        planar_start(control, one_camera, rig.size)


def test_an_exterior_round_trip_keeps_a_pose_behind_the_board():
    pose = Exterior(0.1, 0.2, 0.7, 0.1, -0.2, 0.3)
    rvec, tvec = exterior_to_opencv(pose)
    assert tvec[2] > 0  # OpenCV's z forward: the object frame's origin is in front of the camera
