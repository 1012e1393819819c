"""The picks' own pointing sigma in the one figure path: a Monte Carlo over random rigs of every housing kind.

Each case is a calibration with a random parameter covariance Σ (every housing kind, correlated, prior-like
sigmas) whose TRUE parameters are drawn from N(estimate, Σ) — what "the calibration's error has covariance
Σ" means. Points 1-4 m in front of the rig are imaged by the true cameras, their pixels get pointing noise of
a known σ_p drawn in [0.3, 1] px (different per case, and per side), and are measured with the estimated
calibration with ``pointing_sigma_px`` set to σ_p. The errors of the points and of lengths between them,
normalised by the covariance the figure path states (pointing share + the calibration's share, with the
correlation the common calibration puts between vertices), must have a mean square (NEES) in 0.7-1.5.

The calibration's σ0 (0.06 px, as a board calibration's corners) is far below σ_p: the test fails if the
figure path takes the pointing from σ0 (NEES ≫ 1), as it did before pointing sigmas were their own.
"""

from __future__ import annotations

import numpy as np
import pytest

from usvips.core import housing as housings
from usvips.core.calibration.model import stereo_cameras
from usvips.core.calibration.parameter_names import exterior_of
from usvips.core.camera import EXTERIOR_PARAMETERS, Exterior
from usvips.core.interior import INTERIOR_PARAMETERS
from usvips.core.measurements import measure_picks, vertex_covariance_parts
from usvips.core.pointing import HAND_CLICK_SIGMA_PX
from usvips.core.rig import RelativeOrientation, relative_orientation, right_exterior
from usvips.core.stereo_calibration import ParameterEstimate, StereoCalibration

STATIONS = ("s0", "s1")
SIZE = (1280, 960)
#: prior-like sigmas of the random covariances, per symbol (pixels, metres, radians, dimensionless)
SIGMAS = {"f": 1.0, "xp": 0.8, "yp": 0.8, "sy": 1e-4, "k1": 1e-3, "k2": 1e-3, "p1": 1e-4, "p2": 1e-4,
          "X0": 1e-3, "Y0": 1e-3, "Z0": 1e-3, "omega": 5e-4, "phi": 5e-4, "kappa": 5e-4}
RIGS_PER_KIND = 12
POINTS = 24
LENGTHS = 8


def _symbol(name: str) -> str:
    head = name.split("@")[0]
    return head.rsplit("_", 1)[0] if "_" in head else head


def _values(rng: np.random.Generator, kind: str) -> dict[str, float]:
    values = {}
    for side in ("l", "r"):
        interior = {"f": rng.uniform(900, 1300), "xp": 640 + rng.normal(0, 15), "yp": 480 + rng.normal(0, 15),
                    "sy": 1 + rng.normal(0, 0.01), "k1": rng.normal(-0.08, 0.03), "k2": rng.normal(0, 0.02),
                    "p1": rng.normal(0, 1e-3), "p2": rng.normal(0, 1e-3), "k3": 0.0}
        values.update({f"{p}_{side}": interior[p] for p in INTERIOR_PARAMETERS})
    left = Exterior(rng.uniform(0.4, 0.8), rng.uniform(0.5, 0.9), rng.uniform(2.4, 2.9), *rng.normal(0, 0.04, 3))
    relative = RelativeOrientation(rng.uniform(0.3, 0.5), rng.normal(0, 0.01), rng.normal(0, 0.01),
                                   rng.normal(0, 0.01), rng.uniform(-0.15, -0.05), rng.normal(0, 0.01))
    for suffix, pose in (("_l", left), ("_r", right_exterior(left, relative)), ("_l@s1", left)):
        values.update({f"{p}{suffix}": getattr(pose, p) for p in EXTERIOR_PARAMETERS})
    cls = housings.kind(kind)
    for name in cls.calibration_names:
        spec = cls.spec(_symbol(name))
        value = spec.start + (0.3 * spec.sigma * rng.normal() if spec.sigma else 0.0)
        if spec.lower is not None:
            value = max(value, spec.lower + 0.5 * abs(spec.start - spec.lower))
        values[name] = value
    return values


def _calibration(kind: str, values: dict[str, float], names: tuple[str, ...] | None = None,
                 covariance: np.ndarray | None = None) -> StereoCalibration:
    left, right = stereo_cameras(kind, values, STATIONS, STATIONS[0], SIZE)
    estimates = {name: ParameterEstimate(value, None, "free") for name, value in values.items()}
    return StereoCalibration(left, right, STATIONS, (left.exterior, exterior_of(values, "l", "s1")),
                             relative_orientation(left.exterior, right.exterior), "water", 0.06, estimates,
                             None if names is None else (names, covariance))


def _case(rng: np.random.Generator, kind: str, calibration_share: float):
    """(estimated calibration with covariance, true calibration) of one random rig of ``kind``. The random
    covariance is scaled so that the calibration's share of a point's variance is ``calibration_share`` at
    a typical point with the typical pointing sigma (both shares then matter)."""
    values = _values(rng, kind)
    names = tuple(n for n in values if not n.startswith("k3") and "@" not in n)
    sigmas = np.array([SIGMAS.get(_symbol(n)) or housings.kind(kind).spec(_symbol(n)).sigma or 1e-3 for n in names])
    mixing = rng.normal(size=(len(names), len(names)))
    correlated = mixing @ mixing.T / len(names) + np.eye(len(names))
    scale = sigmas / np.sqrt(np.diag(correlated))
    covariance = correlated * np.outer(scale, scale)
    _, left, right = _imaged(rng, _calibration(kind, values), 8)
    _, pointing, calibration, _, _ = vertex_covariance_parts(_calibration(kind, values, names, covariance), left,
                                                             right, 0, "object", 0.65)
    ratio = np.median(np.diag(calibration)[2::3] / np.diag(pointing)[2::3])  # depth: the largest variances
    covariance = covariance * calibration_share / (1 - calibration_share) / ratio
    truth = dict(values)
    for name, error in zip(names, np.linalg.cholesky(covariance) @ rng.normal(size=len(names)), strict=True):
        truth[name] += error
    return _calibration(kind, values, names, covariance), _calibration(kind, truth)


def _imaged(rng: np.random.Generator, truth: StereoCalibration, n: int):
    """n points 1-4 m in front of the true rig, in the object frame, and their true pixels (n, 2) per side."""
    rig = truth.rig(0, "object")
    left = np.column_stack([rng.uniform(100, 1180, 4 * n), rng.uniform(100, 860, 4 * n)])
    bundle = rig.left.rays(left)
    points = bundle.origins + rng.uniform(1.0, 4.0, (4 * n, 1)) * bundle.directions
    right = rig.right.project(points)
    inside = bundle.ok & right.ok & np.all((right.pixels > 20) & (right.pixels < [1260, 940]), axis=1)
    index = np.flatnonzero(inside)[:n]
    assert index.size == n
    again = rig.left.project(points[index])
    return points[index], again.pixels, right.pixels[index]


def _nees(error: np.ndarray, covariance: np.ndarray) -> float:
    return float(error @ np.linalg.solve(covariance, error)) / len(error)


@pytest.mark.parametrize("kind", housings.names())
def test_stated_sigmas_hold_with_the_picks_pointing_sigma(kind):
    rng = np.random.default_rng([32, len(kind), sum(map(ord, kind))])
    point_nees, length_nees, shares = [], [], []
    for _ in range(RIGS_PER_KIND):
        estimated, truth = _case(rng, kind, rng.uniform(0.15, 0.45))
        points, left, right = _imaged(rng, truth, POINTS)
        sigma = rng.uniform(0.3, 1.0, (POINTS, 2))  # σ_p per vertex and side (px, one coordinate)
        noisy_left = left + rng.normal(size=left.shape) * sigma[:, :1]
        noisy_right = right + rng.normal(size=right.shape) * sigma[:, 1:]
        measured, pointing, calibration, _, _ = vertex_covariance_parts(estimated, noisy_left, noisy_right, 0,
                                                                        "object", sigma)
        full = pointing + calibration
        point_nees += [_nees(measured[i] - points[i], full[3 * i:3 * i + 3, 3 * i:3 * i + 3]) for i in range(POINTS)]
        for i in range(LENGTHS):
            a, b = 2 * i, 2 * i + 1
            m = measure_picks("length", estimated, noisy_left[[a, b]], noisy_right[[a, b]], 0, "object",
                              pointing_sigma_px=sigma[[a, b]], pointing_origin="given")
            length = m.main
            error = length.value - np.linalg.norm(points[a] - points[b])
            length_nees.append((error / length.sigma) ** 2)
            shares.append(length.sigma_calibration / length.sigma)
    assert 0.7 <= np.mean(point_nees) <= 1.5, (kind, np.mean(point_nees))
    assert 0.7 <= np.mean(length_nees) <= 1.5, (kind, np.mean(length_nees))
    assert 0.05 < np.median(shares) < 0.95  # both shares matter in these cases: the test sees both


def test_the_breakdown_adds_in_variance_and_none_is_the_hand_click_default():
    rng = np.random.default_rng(3201)
    estimated, truth = _case(rng, "flat-port", 0.4)
    _, left, right = _imaged(rng, truth, 4)
    m = measure_picks("polygon", estimated, left, right)
    assert m.pointing_origin == "default"
    np.testing.assert_allclose(m.pointing_sigma_px, HAND_CLICK_SIGMA_PX)
    for figure in m.figures:
        assert figure.sigma ** 2 == pytest.approx(figure.sigma_pointing ** 2 + figure.sigma_calibration ** 2,
                                                  rel=1e-9, abs=1e-18)
    given = measure_picks("polygon", estimated, left, right, pointing_sigma_px=HAND_CLICK_SIGMA_PX)
    np.testing.assert_allclose(given.covariance, m.covariance, rtol=1e-9, atol=1e-15)
    corners = measure_picks("polygon", estimated, left, right, pointing_sigma_px=estimated.sigma0_px)
    assert corners.main.sigma_pointing < 0.5 * m.main.sigma_pointing  # σ0 (0.06 px) is not what None means
    without = measure_picks("polygon", _calibration("flat-port", {n: p.value for n, p in
                                                                  estimated.parameters.items()}), left, right)
    assert without.main.sigma_calibration == 0.0
    assert any("pointing only" in mark for mark in without.marks)
