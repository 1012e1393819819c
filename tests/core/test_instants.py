"""An object measured on several instants: random-effects combination tested against the truth of
swimming, bending fish (Monte Carlo), with each instant's figure from the one figure function."""

import numpy as np
import pytest

from usvips.core.errors import InvalidParameterError
from usvips.core.measurements import measure
from usvips.core.measurements.instants import (
    MAX_FRAME_CORRELATION,
    _random_effects,
    combine_figure,
    combine_instants,
    frame_correlation,
    least_variance_weights,
)
from usvips.core.synth.swimming import SwimmingFish


def _fish(rng) -> SwimmingFish:
    return SwimmingFish(start=tuple(rng.uniform([-0.5, -0.3, -4.0], [0.5, 0.3, -1.5])),
                        heading=(np.cos(a := rng.uniform(0, 2 * np.pi)), 0.0, np.sin(a)), up=(0.0, 1.0, 0.0),
                        length=rng.uniform(0.15, 0.6), speed=0.0, bend=rng.uniform(0.0, 0.9),
                        beat_hz=rng.uniform(1.0, 3.0), phase=rng.uniform(0, 2 * np.pi))


def _mean_chord(fish: SwimmingFish) -> float:
    """The truth the combination estimates: the fish's snout–fork distance averaged over a tail beat."""
    times = np.linspace(0.0, 1.0 / fish.beat_hz, 120, endpoint=False)
    return float(np.mean([np.linalg.norm(np.diff(fish.snout_fork(t), axis=0)) for t in times]))


def _vertex_covariance(rng, point) -> np.ndarray:
    """A stereo vertex's covariance: long along the line of sight (3-10 mm), 0.7-2 mm across (m²)."""
    view = point / np.linalg.norm(point)
    across = np.linalg.svd(view[None])[2][1:]
    axes = np.vstack([view, across])
    sigmas = np.array([rng.uniform(0.003, 0.010), *rng.uniform(0.0007, 0.002, 2)])
    return axes.T @ np.diag(sigmas ** 2) @ axes


def _instants(rng, fish: SwimmingFish, k: int, common: np.ndarray | None = None):
    """k instants at random times: each a noisy snout and fork and their length Figure with sigma."""
    figures = []
    for t in rng.uniform(0.0, 10.0, k):
        truth = fish.snout_fork(t)
        covariances = np.array([_vertex_covariance(rng, p) for p in truth])
        noisy = truth + np.array([rng.multivariate_normal(np.zeros(3), c) for c in covariances])
        if common is not None:
            noisy = noisy + common
        figures.append(measure("length", noisy, covariances).figures)
    return figures


def test_over_many_bending_fish_the_combined_length_is_honest_and_better_than_one_instant():
    rng = np.random.default_rng(2025)
    normalised, combined_errors, single_errors = [], [], []
    for _ in range(400):
        fish = _fish(rng)
        instants = _instants(rng, fish, int(rng.integers(3, 11)))
        length = combine_instants(instants)[0]
        truth = _mean_chord(fish)
        normalised.append(((length.value - truth) / length.sigma) ** 2)
        combined_errors.append(length.value - truth)
        single_errors.append(instants[0][0].value - truth)
    msne = float(np.mean(normalised))
    print(f"MSNE {msne:.3f}")
    assert 0.7 <= msne <= 1.5, msne
    assert np.sqrt(np.mean(np.square(combined_errors))) < 0.7 * np.sqrt(np.mean(np.square(single_errors)))


def test_a_calibration_error_common_to_all_instants_is_kept_in_sigma_when_given():
    rng = np.random.default_rng(7)
    given, ignored = [], []
    common_sigma = 0.006  # m: the length's part from the calibration, common to every instant
    for _ in range(300):
        fish = _fish(rng)
        # a common scale error of the calibration lengthens every instant alike
        scale = rng.normal(0.0, common_sigma / fish.length)
        instants = _instants(rng, fish, 8)
        shifted = [[f.__class__(f.name, f.value * (1 + scale), f.sigma, f.unit) for f in figs] for figs in instants]
        truth = _mean_chord(fish)
        with_common = combine_instants(shifted, {"length": common_sigma * np.mean(
            [figs[0].value for figs in shifted]) / fish.length})[0]
        without = combine_instants(shifted)[0]
        given.append(((with_common.value - truth) / with_common.sigma) ** 2)
        ignored.append(((without.value - truth) / without.sigma) ** 2)
    assert 0.7 <= np.mean(given) <= 1.5
    assert np.mean(ignored) > 1.5  # averaging instants does not average out a common error


def test_a_planted_outlying_instant_is_named_and_agreeing_instants_are_not_flagged():
    rng = np.random.default_rng(11)
    named, false_alarms, tests = 0, 0, 0
    for _ in range(200):
        fish = _fish(rng)
        instants = [figs[0] for figs in _instants(rng, fish, 7)]
        values = np.array([f.value for f in instants])
        sigmas = np.array([f.sigma for f in instants])
        labels = [f"frame {100 + 25 * i}" for i in range(7)]
        clean = combine_figure(values, sigmas, labels=labels)
        false_alarms += len(clean.outliers) > 0
        tests += 1
        planted = int(rng.integers(0, 7))
        wrong = values.copy()
        wrong[planted] += 0.2 * fish.length  # the fork picked on the wrong fin
        result = combine_figure(wrong, sigmas, labels=labels)
        if result.outliers == (planted,):
            named += 1
            assert labels[planted] in result.summary()
    assert named >= 0.95 * tests
    assert false_alarms <= 0.1 * tests


def test_the_chi_square_test_holds_its_size_for_a_rigid_object_and_sees_bending():
    rng = np.random.default_rng(3)
    rejected_rigid, rejected_bending = 0, 0
    for _ in range(300):
        k = int(rng.integers(4, 10))
        sigmas = rng.uniform(0.002, 0.008, k)
        rigid = combine_figure(0.4 + rng.normal(0, sigmas), sigmas)
        rejected_rigid += not rigid.agree
        assert rigid.dof == k - 1 and 0 <= rigid.between_share <= 1
        bending = combine_figure(0.4 + rng.normal(0, 0.03, k) + rng.normal(0, sigmas), sigmas)
        rejected_bending += not bending.agree
    assert 0.02 * 300 <= rejected_rigid <= 0.09 * 300
    assert rejected_bending >= 0.9 * 300


def test_between_instant_spread_dominates_sigma_when_the_fish_bends_much_more_than_it_is_measured():
    rng = np.random.default_rng(5)
    sigmas = np.full(10, 0.001)
    result = combine_figure(0.5 + rng.normal(0, 0.02, 10), sigmas)
    assert result.between_share > 0.9
    assert result.tau == pytest.approx(0.02, rel=0.6)
    agreeing = combine_figure(0.5 + rng.normal(0, 1e-6, 10), sigmas)
    assert agreeing.between_share == 0.0 and agreeing.tau == 0.0


def test_a_single_instant_is_itself_and_two_calibrations_are_refused_by_name():
    one = combine_figure([0.412], [0.004], common_sigma=0.003)
    assert one.value == 0.412 and one.sigma == pytest.approx(0.005) and one.count == 1
    assert one.outliers == () and one.agree
    with pytest.raises(InvalidParameterError, match="frame 12.*calibration 3.*frame 40.*calibration 5"):
        combine_figure([0.41, 0.42], [0.004, 0.004], labels=["frame 12", "frame 40"], calibrations=[3, 5])


@pytest.mark.parametrize("values, sigmas, match", [
    ([], [], "none given"),
    ([0.4, 0.41], [0.004], "expected 2 sigmas"),
    ([0.4, np.nan], [0.004, 0.004], "instant 2"),
    ([0.4, 0.41], [0.004, 0.0], "positive sigma"),
])
def test_bad_instants_are_named(values, sigmas, match):
    with pytest.raises(InvalidParameterError, match=match):
        combine_figure(values, sigmas)


def test_instants_of_different_kinds_are_refused():
    length = measure("length", np.array([[0, 0, -2.0], [0.3, 0, -2.0]]), np.eye(6) * 1e-6).figures
    point = measure("point", np.array([[0, 0, -2.0]]), np.eye(3) * 1e-6).figures
    with pytest.raises(InvalidParameterError, match="instant 2.*one object is one kind"):
        combine_instants([length, point])


def test_instants_tracked_from_one_pick_keep_its_error_whole_and_average_the_rest():
    """Tracked instants carry their pick's error to every frame: combined as independent ones their sigma
    shrinks like 1/√k while their error does not; with ``shared_pointing`` the carried error stays whole
    and only the tracking noise and the bending average out."""
    rng = np.random.default_rng(19)
    shared, independent = [], []
    for _ in range(400):
        fish = _fish(rng)
        k = int(rng.integers(3, 11))
        sigma = rng.uniform(0.001, 0.004)  # m: the length's sigma from its picks (pointing)
        carried = rng.normal(0.0, sigma)  # the pick's error, followed by the tracker to every frame
        chords = [np.linalg.norm(np.diff(fish.snout_fork(t), axis=0)) for t in rng.uniform(0.0, 10.0, k)]
        values = np.array(chords) + carried + rng.normal(0.0, 0.2 * sigma, k)  # and the tracker's own noise
        truth = _mean_chord(fish)
        with_carried = combine_figure(values, np.full(k, sigma), sigma, shared_pointing=True)
        as_independent = combine_figure(values, np.full(k, sigma))
        shared.append(((with_carried.value - truth) / with_carried.sigma) ** 2)
        independent.append(((as_independent.value - truth) / as_independent.sigma) ** 2)
        assert with_carried.sigma >= sigma  # never below the carried error
    print(f"MSNE tracked as shared {np.mean(shared):.3f}, as independent {np.mean(independent):.3f}")
    assert 0.7 <= np.mean(shared) <= 1.5, np.mean(shared)
    assert np.mean(independent) > 2.0  # what combining them as independent instants claimed


def _correlated_errors(rng, rho: float, sigmas: np.ndarray) -> np.ndarray:
    """Errors with cov(e_i, e_j) = rho sigma_i sigma_j between instants and var(e_i) = sigma_i²."""
    return sigmas * (np.sqrt(rho) * rng.normal() + np.sqrt(1.0 - rho) * rng.normal(size=sigmas.size))


def test_frame_correlation_recovers_the_correlation_of_instants_errors():
    """Over random correlations, counts of instants and sigmas that differ by instant (and a sigma stated
    twice too large: it is a correlation, so the scale does not bias it), the estimate lies within its
    stated uncertainty: the mean squared normalised error of the estimates is near 1."""
    rng = np.random.default_rng(23)
    normalised = []
    for _ in range(40):
        rho = rng.uniform(0.0, 0.85)
        stated = rng.choice([1.0, 2.0])
        groups = []
        for _ in range(int(rng.integers(60, 150))):
            sigmas = rng.uniform(0.5, 3.0, int(rng.integers(2, 7)))
            groups.append(_correlated_errors(rng, rho, sigmas) / (stated * sigmas))
        found = frame_correlation(groups)
        assert found.objects == len(groups) and found.uncertainty < 0.15
        if not found.bound:
            normalised.append((found.value - rho) / found.uncertainty)
    print(f"MSNE of the frame correlation {np.mean(np.square(normalised)):.2f} over {len(normalised)} cases")
    assert len(normalised) >= 30
    assert 0.5 <= np.mean(np.square(normalised)) <= 1.8


def test_frame_correlation_names_too_few_objects_and_says_when_on_its_bound():
    rng = np.random.default_rng(5)
    with pytest.raises(InvalidParameterError, match="at least 10"):
        frame_correlation([rng.normal(size=3) for _ in range(9)] + [[0.5]] * 20)
    with pytest.raises(InvalidParameterError, match="finite"):
        frame_correlation([rng.normal(size=3) for _ in range(11)] + [[np.nan, 1.0]])
    with pytest.raises(InvalidParameterError, match="finite"):  # even an object seen once
        frame_correlation([rng.normal(size=3) for _ in range(11)] + [[np.inf]])
    carried = frame_correlation([np.full(4, rng.normal()) for _ in range(30)])  # one error on every instant
    assert carried.bound and carried.value == MAX_FRAME_CORRELATION
    opposed = frame_correlation([np.array([z, -z]) for z in rng.normal(size=30)])
    assert opposed.bound and opposed.value == 0.0


def test_instants_whose_errors_correlate_are_combined_with_an_honest_sigma():
    """A model pointing on its own at one fish on every frame errs partly alike on each (correlation rho):
    combined with ``shared_fraction`` = rho the NEES is near 1; as independent instants the sigma is too
    small, and with the whole error shared (as tracked instants) too large — what was done before."""
    rng = np.random.default_rng(29)
    honest, independent, whole = [], [], []
    for _ in range(1500):
        rho = rng.uniform(0.15, 0.6)
        k = int(rng.integers(3, 9))
        sigmas = rng.uniform(0.002, 0.006, k)  # m: each instant's pointing sigma of the length
        calibration = rng.uniform(0.0, 0.002)  # m: common to every instant
        truth = rng.uniform(0.2, 0.6)
        values = truth + _correlated_errors(rng, rho, sigmas) + rng.normal(0.0, calibration)
        for out, kwargs in ((honest, {"shared_fraction": rho}), (independent, {}),
                            (whole, {"shared_pointing": True})):
            common = (np.hypot(calibration, np.sqrt(np.mean(sigmas ** 2))) if "shared_pointing" in kwargs
                      else calibration)
            combined = combine_figure(values, sigmas, common, **kwargs)
            out.append(((combined.value - truth) / combined.sigma) ** 2)
    print(f"NEES with the frame correlation {np.mean(honest):.3f}, independent {np.mean(independent):.3f}, "
          f"whole error shared {np.mean(whole):.3f}")
    assert 0.85 <= np.mean(honest) <= 1.2
    assert np.mean(independent) > 1.5
    assert np.mean(whole) < 0.75


def test_a_models_instants_among_a_persons_are_combined_with_an_honest_sigma():
    """Some instants a model pointed at (their errors correlate by rho), others a person picked or corrected
    (independent): one rho_i per instant (rho for the model's, 0 for the person's) gives a NEES near 1;
    taking them all as independent — what a reviewer's correction of one instant used to do — is too sure.
    An instant of which the person moved half the points (rho_i = rho / 2 for its share) errs cautious."""
    rng = np.random.default_rng(31)
    honest, independent, half = [], [], []
    for _ in range(1500):
        rho = rng.uniform(0.3, 0.6)
        k = int(rng.integers(4, 9))
        person = rng.permutation(k) < int(rng.integers(1, k - 2))  # at least three of the model's instants
        sigmas = rng.uniform(0.002, 0.006, k)
        calibration = rng.uniform(0.0, 0.002)
        truth = rng.uniform(0.2, 0.6)
        errors = np.where(person, sigmas * rng.normal(size=k), _correlated_errors(rng, rho, sigmas))
        values = truth + errors + rng.normal(0.0, calibration)
        fractions = np.where(person, 0.0, rho)
        for out, shares in ((honest, fractions), (independent, 0.0), (half, np.where(person, rho / 2, rho))):
            combined = combine_figure(values, sigmas, calibration, shared_fraction=shares)
            out.append(((combined.value - truth) / combined.sigma) ** 2)
    print(f"NEES per instant {np.mean(honest):.3f}, all independent {np.mean(independent):.3f}, a person's "
          f"instants at half the share {np.mean(half):.3f}")
    assert 0.85 <= np.mean(honest) <= 1.2
    assert np.mean(independent) > 1.3
    assert np.mean(half) < np.mean(honest)


def test_one_share_for_every_instant_is_the_same_as_one_given_per_instant():
    values, sigmas = [0.30, 0.31, 0.29, 0.305], [0.004, 0.003, 0.005, 0.004]
    one = combine_figure(values, sigmas, 0.001, shared_fraction=0.4)
    each = combine_figure(values, sigmas, 0.001, shared_fraction=[0.4] * 4)
    assert (each.value, each.sigma) == (one.value, one.sigma)
    assert combine_figure(values, sigmas, 0.001, shared_fraction=[0.4, 0.4, 0.0, 0.4]).sigma < one.sigma


@pytest.mark.parametrize("fractions, words", [([0.3, 0.3], "expected one value or 3 for 3 instants"),
                                              ([0.3, 1.0, 0.3], "instant 2: must lie in"),
                                              ([0.3, 0.3, float("nan")], "instant 3: must lie in")])
def test_a_share_per_instant_that_is_wrong_is_refused_naming_the_instant(fractions, words):
    with pytest.raises(InvalidParameterError, match=words):
        combine_figure([0.30, 0.31, 0.29], [0.004, 0.004, 0.005], shared_fraction=fractions)


@pytest.mark.parametrize("kwargs, words", [({"shared_fraction": 1.0}, "shared_fraction: must lie in"),
                                           ({"shared_fraction": -0.1}, "shared_fraction: must lie in"),
                                           ({"shared_fraction": float("nan")}, "shared_fraction: must lie in"),
                                           ({"shared_fraction": 0.3, "shared_pointing": True}, "not with shared")])
def test_a_frame_correlation_outside_its_range_is_refused_by_name(kwargs, words):
    with pytest.raises(InvalidParameterError, match=words):
        combine_figure([0.30, 0.31, 0.29], [0.004, 0.004, 0.005], **kwargs)


def test_instants_of_very_different_sigmas_sharing_a_models_error_are_combined_honestly_and_no_worse():
    """A model's instants of one fish whose sigmas differ up to eightfold (a fish near and far, edge-on and
    side-on), some a person's: the least-variance weights give a NEES as honest as the random-effects
    weights did (both a little cautious here: the Hartung-Knapp floor with two to seven instants) with a
    smaller sigma, and where the instants agree (no spread to widen sigma) the combination is never less
    precise than its best instant alone — with the random-effects weights a far instant made it worse."""
    rng = np.random.default_rng(37)
    nees, before_nees, sigma, before_sigma, ratios = [], [], [], [], []
    for _ in range(1500):
        rho = rng.uniform(0.2, 0.6)
        k = int(rng.integers(2, 8))
        sigmas = rng.uniform(0.002, 0.004, k) * np.exp(rng.uniform(0.0, np.log(8.0), k))
        person = rng.uniform(size=k) < 0.25
        fractions = np.where(person, 0.0, rho)
        truth = rng.uniform(0.2, 0.6)
        values = truth + np.where(person, sigmas * rng.normal(size=k), _correlated_errors(rng, rho, sigmas))
        combined = combine_figure(values, sigmas, shared_fraction=fractions)
        nees.append(((combined.value - truth) / combined.sigma) ** 2)
        sigma.append(combined.sigma)
        # the random-effects weights' estimate and sigma (what was done before), from the same estimates
        own = (1 - fractions) * sigmas ** 2
        _, variance, tau2, _, _ = _random_effects(values, own)
        weights = 1 / (own + tau2) / (1 / (own + tau2)).sum()
        before = np.sqrt(variance + (weights @ (np.sqrt(fractions) * sigmas)) ** 2)
        before_nees.append(((weights @ values - truth) / before) ** 2)
        before_sigma.append(before)
        agreeing = combine_figure(np.full(k, truth), sigmas, shared_fraction=fractions)
        ratios.append(agreeing.sigma / sigmas.min())
        assert agreeing.weights.min() >= 0 and np.isclose(agreeing.weights.sum(), 1.0)
    print(f"NEES {np.mean(nees):.3f} (random-effects weights {np.mean(before_nees):.3f}); mean sigma "
          f"{np.mean(sigma) * 1e3:.2f} mm ({np.mean(before_sigma) * 1e3:.2f}); agreeing instants' sigma over the "
          f"best instant's: at most {max(ratios):.4f} (random-effects weights could exceed 1)")
    assert 0.7 <= np.mean(nees) <= 1.2 and abs(np.mean(nees) - np.mean(before_nees)) < 0.1
    assert np.mean(sigma) < 0.97 * np.mean(before_sigma)
    assert max(ratios) <= 1.0 + 1e-9


def test_a_near_and_a_far_instant_of_a_models_fish_combine_to_no_worse_than_the_near_one():
    """The fish seen on rov_flatport's video at 16.9 and 56.8 mm (rho 0.4): 17.8 mm with the random-effects
    weights, now the near instant's 16.9 mm (the far one would get a negative weight: it gets none)."""
    combined = combine_figure([0.300, 0.301], [0.0169, 0.0568], shared_fraction=0.4)
    assert combined.sigma == pytest.approx(0.0169, rel=1e-6)
    assert combined.weights.tolist() == [1.0, 0.0]


def test_least_variance_weights_are_the_constrained_minimum():
    """Over random one-factor covariances: weights >= 0 summing to 1, none of many random feasible weights
    has a smaller variance, and without a shared factor they are the inverse-variance weights."""
    rng = np.random.default_rng(41)
    for _ in range(300):
        k = int(rng.integers(1, 9))
        own = rng.uniform(0.1, 10.0, k) ** 2
        loading = rng.uniform(0.0, 3.0, k) * (rng.uniform(size=k) < 0.8)
        weights = least_variance_weights(own, loading)
        covariance = np.diag(own) + np.outer(loading, loading)
        assert weights.min() >= 0 and weights.sum() == pytest.approx(1.0)
        best = weights @ covariance @ weights
        others = rng.dirichlet(np.full(k, 0.5), 200)
        assert np.all(np.einsum("ij,jk,ik->i", others, covariance, others) >= best * (1 - 1e-9))
        plain = least_variance_weights(own, np.zeros(k))
        np.testing.assert_allclose(plain, (1 / own) / (1 / own).sum(), rtol=1e-10)
