"""The figure path's σ where first order fails: short lengths far away.

A Monte Carlo over random rigs of every housing kind: fish 1-6 m in front of the rig, 0.1-0.6 m long, any
heading, their snout and fork imaged through the housing and picked with realistic noise — half as a
person's clicks (Gaussian, the hand-click σ), half as a detector's keypoints (Student t of 5 degrees of
freedom scaled to a σ of 1-2 px: heavy tails) — and measured by the one figure path with that σ given.
The normalised squared errors of the lengths (NEES) and of the vertices are binned by the ratio of the
vertices' largest σ to the true length. First order alone fails where that ratio grows: a few estimates
whose segment the noise turned across the depth direction have errors of many of their σ (a heavy tail
that dominates its mean NEES in any one run); the stated σ, with its second-order part, has no such tail,
holds near 1 below a ratio of 0.15 and is conservative above it. Then unit checks: the second-order σ of a length with a
known Gaussian vertex covariance is the sampled root mean square error; a linear figure is unchanged.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.detection.stereo_scenes import SIZE, random_calibration
from usvips.core import housing as housings
from usvips.core.measurements import kind
from usvips.core.measurements.batch import measure_picks_many
from usvips.core.measurements.figures import propagate_all
from usvips.core.measurements.kinds.length import Length
from usvips.core.pointing import HAND_CLICK_SIGMA_PX

RIGS = 10
FISH = 40
#: bins of the ratio (vertices' largest σ) / length
BINS = (0.0, 0.05, 0.15, 0.3, np.inf)


def _fish(rng: np.random.Generator, rig, n: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """n fish (2, 3) m seen by both cameras, with their true pixels (2, 2) per side."""
    found = []
    while len(found) < n:
        bundle = rig.left.rays(np.array([[rng.uniform(100, 1180), rng.uniform(100, 860)]]))
        if not bundle.ok[0]:
            continue
        snout = bundle.origins[0] + rng.uniform(1.0, 6.0) * bundle.directions[0]
        heading = rng.normal(size=3)
        body = np.vstack([snout, snout + rng.uniform(0.1, 0.6) * heading / np.linalg.norm(heading)])
        left, right = rig.left.project(body), rig.right.project(body)
        if all(p.ok.all() and np.all((p.pixels > 20) & (p.pixels < np.array(SIZE) - 20)) for p in (left, right)):
            found.append((body, left.pixels, right.pixels))
    return found


def _picked(rng: np.random.Generator, pixels: np.ndarray, sigma: float, heavy: bool) -> np.ndarray:
    if not heavy:
        return pixels + rng.normal(0.0, sigma, pixels.shape)
    return pixels + rng.standard_t(5, pixels.shape) * sigma / np.sqrt(5 / 3)


def monte_carlo(housing: str, rng: np.random.Generator, rigs: int = RIGS, fish: int = FISH) -> np.ndarray:
    """Rows (ratio, length NEES as stated, length NEES first order alone, the vertices' mean NEES)."""
    rows = []
    for _ in range(rigs):
        calibration = random_calibration(rng, housing)
        bodies = _fish(rng, calibration.rig(0, "object"), fish)
        heavy = rng.uniform(size=fish) < 0.5
        sigmas = np.where(heavy, rng.uniform(1.0, 2.0, fish), HAND_CLICK_SIGMA_PX)
        left = [_picked(rng, b[1], s, h) for b, s, h in zip(bodies, sigmas, heavy, strict=True)]
        right = [_picked(rng, b[2], s, h) for b, s, h in zip(bodies, sigmas, heavy, strict=True)]
        measured = measure_picks_many(["length"] * fish, calibration, left, right, 0, "object", list(sigmas))
        for m, (body, _, _) in zip(measured, bodies, strict=True):
            truth = np.linalg.norm(body[1] - body[0])
            blocks = [m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3] for i in range(2)]
            largest = max(np.sqrt(np.linalg.eigvalsh(b)[-1]) for b in blocks)
            first = propagate_all(Length.values, m.points, m.covariance, many=Length.values_many,
                                  nonlinear=False)[1][0, 0]
            error = m.main.value - truth
            points = np.mean([(m.points[i] - body[i]) @ np.linalg.solve(blocks[i], m.points[i] - body[i]) / 3
                              for i in range(2)])
            rows.append((largest / truth, (error / m.main.sigma) ** 2, error ** 2 / first, points))
    return np.array(rows)


def _binned(rows: np.ndarray) -> list[np.ndarray]:
    where = np.digitize(rows[:, 0], BINS) - 1
    return [rows[where == b] for b in range(len(BINS) - 1)]


@pytest.fixture(scope="module")
def surveys() -> dict[str, np.ndarray]:
    return {h: monte_carlo(h, np.random.default_rng([41, sum(map(ord, h))])) for h in housings.names()}


@pytest.mark.parametrize("housing", housings.names())
def test_lengths_near_and_far_have_honest_sigmas(surveys, housing):
    """Per bin of σ/L: the vertices' NEES and the lengths' near 1 where the ratio is below 0.15; beyond it
    the stated σ is never too small (NEES ≤ 1.4) and at most ~1.8 times too large (NEES ≥ 0.3): there the
    root mean square error about the estimate covers the rare foreshortened fish and so is conservative for
    the many others (no σ computed from the estimate alone can be both; docs/design.md says why)."""
    table = [(BINS[b], len(r), *r[:, 1:].mean(axis=0)) for b, r in enumerate(_binned(surveys[housing]))]
    print(housing, "(bin, count, NEES stated, NEES first order, vertices' NEES):",
          [tuple(round(float(x), 2) for x in t) for t in table])
    for low, count, stated, _, points in table:
        assert count >= 40, (low, count)
        assert 0.7 <= points <= 1.4, (low, points)  # the intersection's own nonlinearity does not show
        assert (0.7 if low < 0.15 else 0.3) <= stated <= 1.4, (low, stated)


def _holds_far_away(nees: np.ndarray) -> bool:
    """Whether a σ holds for lengths far away: mean NEES ≤ 1.4 and at most 0.5 % of the errors beyond 4σ
    (the keypoints' heavy tails give some; the foreshortened fish, if their σ does not cover them, more)."""
    return bool(np.mean(nees) <= 1.4 and np.mean(nees > 16) <= 0.005)


def test_first_order_alone_fails_far_away_and_the_stated_sigma_holds(surveys):
    """Over every housing kind, lengths with σ/L ≥ 0.15: the stated σ holds (:func:`_holds_far_away`), the
    first-order σ alone does not — its errors beyond 4σ, estimates whose segment the noise turned across
    the depth direction so that J Σ Jᵀ holds the lateral σ alone, are several times as frequent. Below
    0.15 the two barely differ."""
    rows = np.concatenate(list(surveys.values()))
    far, near = rows[rows[:, 0] >= 0.15], rows[rows[:, 0] < 0.15]
    print(f"far: {len(far)} lengths, NEES stated {far[:, 1].mean():.2f}, first order {far[:, 2].mean():.2f}; "
          f"beyond 4σ: stated {np.mean(far[:, 1] > 16):.3f}, first order {np.mean(far[:, 2] > 16):.3f}")
    assert _holds_far_away(far[:, 1])
    assert not _holds_far_away(far[:, 2])
    assert abs(np.mean(near[:, 1]) / np.mean(near[:, 2]) - 1) < 0.15


def _across_the_view(rng: np.random.Generator, ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """A segment of length 1 m and a random joint covariance whose largest σ, ``ratio`` m, is along a
    direction across the segment (as a stereo vertex's depth for a fish across the view)."""
    points = np.array([[0.0, 0.0, 0.0], rng.normal(size=3)])
    points[1] /= np.linalg.norm(points[1])
    covariance = np.zeros((6, 6))
    for i in range(2):
        depth = np.cross(points[1], rng.normal(size=3))
        depth /= np.linalg.norm(depth)
        root = rng.normal(scale=0.1 * ratio, size=(3, 3)) + ratio * np.outer(depth, depth)
        covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3] = root @ root.T
    return points, covariance


def test_a_length_s_sigma_is_its_sampled_root_mean_square_error():
    """For x ~ N(x̂, Σ), the root mean square of |x₂ − x₁| − |x̂₂ − x̂₁| sampled against the stated σ and the
    first-order one: the stated one within 10 % (σ/L up to 0.25), the first-order one farther, and 20 % short
    or more from σ/L 0.2 on (it holds the lateral σ alone)."""
    rng = np.random.default_rng(42)
    for ratio in np.repeat([0.05, 0.1, 0.15, 0.2, 0.25], 4):
        points, covariance = _across_the_view(rng, ratio)
        samples = points.ravel() + rng.multivariate_normal(np.zeros(6), covariance, 40_000)
        errors = Length.values_many(samples.reshape(-1, 2, 3))[:, 0] - 1.0
        sampled = np.sqrt(np.mean(errors ** 2))
        stated = np.sqrt(propagate_all(Length.values, points, covariance, many=Length.values_many)[1][0, 0])
        first = np.sqrt(propagate_all(Length.values, points, covariance, nonlinear=False)[1][0, 0])
        assert stated == pytest.approx(sampled, rel=0.1), (ratio, stated, sampled)
        assert abs(stated / sampled - 1) < abs(first / sampled - 1), (ratio, stated, first, sampled)
        assert ratio < 0.2 or first < 0.8 * sampled, (ratio, first, sampled)


def test_a_linear_figure_keeps_its_first_order_sigma():
    rng = np.random.default_rng(43)
    for _ in range(20):
        points = rng.normal(size=(1, 3))
        root = rng.normal(scale=0.5, size=(3, 3))  # large: linearity, not smallness, keeps it first order
        covariance = root @ root.T
        figures = kind("point").figures(points, covariance)
        np.testing.assert_allclose([f.value for f in figures], points[0], rtol=0, atol=0)
        np.testing.assert_allclose([f.sigma for f in figures], np.sqrt(np.diag(covariance)), rtol=1e-9)


def test_the_breakdown_still_adds_in_variance_and_angles_are_differenced_round_the_circle():
    rng = np.random.default_rng(44)
    points = np.array([[0.0, 0.0, 2.0], [0.0, 0.2, 2.0]])  # bearing 0: a noisy bearing wraps through 2π
    pointing = np.diag(np.tile([0.002, 0.002, 0.04], 2) ** 2)
    root = rng.normal(scale=0.01, size=(6, 6))
    total = pointing + root @ root.T
    figures = {f.name: f for f in kind("length").figures(points, total, pointing)}
    first = propagate_all(Length.values, points, total, periodic=np.array([False, True, True]), nonlinear=False)[1]
    for i, figure in enumerate(figures.values()):
        assert figure.sigma ** 2 == pytest.approx(figure.sigma_pointing ** 2 + figure.sigma_calibration ** 2,
                                                  rel=1e-9)
        assert figure.sigma >= np.sqrt(first[i, i]) * (1 - 1e-9)
    assert figures["bearing"].sigma < 0.5  # radians: a 2π jump would make it π-sized
    assert figures["length"].sigma > 1.05 * np.sqrt(first[0, 0])  # σ/L 0.2: the second-order part shows


def test_a_circle_standing_vertical_has_the_sigma_of_its_normal_s_direction_not_of_its_sign():
    """The "upward" rule flips the normal of a circle standing vertical between shifted vertex sets; the
    normal is differenced as a direction (the kind's axial figures), so its σ is the direction's: before,
    a circle standing exactly vertical had σ ≈ 4·10⁴ for the normal's main component."""
    angles = np.linspace(0, 2 * np.pi, 7)[:-1]
    for tilt in (0.0, 0.05, 0.3):
        points = np.column_stack([0.1 * np.cos(angles), 2 + tilt * 0.1 * np.sin(angles), 0.1 * np.sin(angles)])
        covariance = np.kron(np.eye(6), np.diag([1e-6, 4e-4, 1e-6]))  # 2 cm in depth (Y), 1 mm across
        figures = {f.name: f for f in kind("circle").figures(points, covariance)}
        assert figures["normal_Y"].sigma < 0.05, (tilt, figures["normal_Y"])
        assert 0.05 < figures["normal_Z"].sigma < 0.2 and 0.05 < figures["normal_X"].sigma < 0.2
