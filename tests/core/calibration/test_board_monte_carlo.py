"""Monte Carlo over random rigs calibrated from board views: both phases recover the truth.

Each rig (focal length, principal point, y-scale, distortion, baseline and toe-in; a board of 7-10 × 5-7
corners at 2-4 cm; views at 0.4-1.0 m, tilted 15-45°; pointing noise 0.2-0.5 px) is calibrated in air
from 15 board views and then underwater through its housing from 15 more. It then measures what it never
saw, in its own frame: random points in front of it, and a fresh view of the board whose adjacent-corner
spacings and diagonal are known. The errors against the truth, normalised by the covariance the
calibration reports (pointing + the calibration's own, correlated between points), must have a mean
square near 1 (0.7-1.5)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.board_scenes import board, observe_views, random_rig, random_views, view_pose
from usvips.core.calibration import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.calibration.uncertainty import joint_covariance
from usvips.core.camera import Exterior

VIEWS = 15
RIGS = {"air": 20, "flat-port": 20, "dome-port": 16, "dome-cover": 12}
ORIGIN = Exterior(0.0, 0.0, 0.0)


def _checks(calibration, rig, target, rng, noise):
    """Normalised squared errors of random points (per coordinate) and of known board distances, measured
    in the rig frame with the rig at the origin."""
    stereo = rig.at(ORIGIN)
    depth = rng.uniform(0.45, 1.0, 40)
    half = 0.3 * depth
    truth = np.column_stack([rng.uniform(-half, half) + 0.5 * rig.relative.base[0], rng.uniform(-half, half),
                             -depth])
    pl, pr = stereo.left.project(truth), stereo.right.project(truth)
    seen = np.flatnonzero(pl.ok & pr.ok)
    left = pl.pixels[seen] + rng.normal(0, noise, (seen.size, 2))
    right = pr.pixels[seen] + rng.normal(0, noise, (seen.size, 2))
    result, covariance = joint_covariance(calibration, left, right, frame="rig")
    points = []
    for k in np.flatnonzero(result.ok):
        error = result.points[k] - truth[seen[k]]
        points.append(float(error @ np.linalg.solve(covariance[3 * k:3 * k + 3, 3 * k:3 * k + 3], error)) / 3)
    # a fresh board view: its corners in the rig frame (the pose places the board in front of the rig)
    pose = view_pose(target, rig, rng, rng.uniform(0.5, 0.9), rng.uniform(10, 40))
    corners = pose.to_camera(target.xyz)
    pl, pr = stereo.left.project(corners), stereo.right.project(corners)
    seen = np.flatnonzero(pl.ok & pr.ok)
    left = pl.pixels[seen] + rng.normal(0, noise, (seen.size, 2))
    right = pr.pixels[seen] + rng.normal(0, noise, (seen.size, 2))
    result, covariance = joint_covariance(calibration, left, right, frame="rig")
    index = {int(target.ids[i]): k for k, i in enumerate(seen) if result.ok[k]}
    columns = int(round(np.ptp(target.xyz[:, 0]) / (target.xyz[1, 0] - target.xyz[0, 0]))) + 1
    pairs = [(i, i + 1) for i in index if i + 1 in index and (i + 1) % columns != 0][::3]
    corner_ids = sorted(index)
    pairs.append((corner_ids[0], corner_ids[-1]))  # the diagonal of what is seen
    lengths = []
    for i, j in pairs:
        a, b = index[i], index[j]
        d_est = result.points[a] - result.points[b]
        d_true = np.linalg.norm(corners[seen[a]] - corners[seen[b]])
        unit = d_est / np.linalg.norm(d_est)
        gradient = np.concatenate([unit, -unit])
        rows = np.r_[3 * a:3 * a + 3, 3 * b:3 * b + 3]
        variance = gradient @ covariance[np.ix_(rows, rows)] @ gradient
        lengths.append((np.linalg.norm(d_est) - d_true) ** 2 / variance)
    return points, lengths


def _one_rig(kind: str, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    target = board(int(rng.integers(7, 11)), int(rng.integers(5, 8)), rng.uniform(0.02, 0.04))
    rig = random_rig(rng)
    noise = rng.uniform(0.2, 0.5)
    options = CalibrationOptions(sigma_px=0.5, image_size=rig.size, control_exact=True)  # the default sigma
    air_views = observe_views(target, rig, random_views(target, rig, rng, VIEWS), rng, noise, "a")
    result = calibrate_air(target, air_views, options)
    if kind != "air":
        rig = rig.in_water(kind, rng)
        water_views = observe_views(target, rig, random_views(target, rig, rng, VIEWS, (0.5, 1.0)), rng, noise, "w")
        result = calibrate_water(result.calibration, kind, target, water_views, options)
    points, lengths = _checks(result.calibration, rig, target, rng, noise)
    return dict(report=result.report, noise=noise, points=points, lengths=lengths)


def _summary(kind: str, runs: list[dict]) -> dict[str, float]:
    for k, run in enumerate(runs):
        report = run["report"]
        assert report.converged, f"{kind} rig {k}: {report.reason}"
        assert 0.75 < report.sigma0_px / run["noise"] < 1.3, f"{kind} rig {k}: sigma0 {report.sigma0_px:.3f}"
    return {figure: float(np.mean(np.concatenate([run[figure] for run in runs]))) for figure in ("points", "lengths")}


@pytest.mark.slow
@pytest.mark.parametrize("kind", list(RIGS))
def test_board_calibrations_over_many_rigs_recover_the_truth(kind):
    runs = [_one_rig(kind, 5000 + k) for k in range(RIGS[kind])]
    msne = _summary(kind, runs)
    print(f"{kind}: MSNE {msne}")
    for figure, value in msne.items():
        assert 0.7 <= value <= 1.5, f"{kind} {figure}: mean squared normalised error {value:.2f}"


def test_one_board_rig_in_air_is_honest():
    """The quick form (one rig, in air): the check points' errors are of the size the covariance says."""
    run = _one_rig("air", 4000)
    msne = _summary("air", [run])
    assert 0.4 <= msne["points"] <= 2.0
