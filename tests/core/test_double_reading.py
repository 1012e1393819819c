"""Double reading, against simulated readers: two noisy readings of the same fish, with planted
disagreements, fish only one reader measured, species mistakes and fish schooling close together."""

from __future__ import annotations

import math

import numpy as np
import pytest

from usvips.core.double_reading import LIMITS_Z, ReaderObjects, compare_readers, match_objects, taxa_agree
from usvips.core.errors import InvalidParameterError

SPECIES = np.array(["Pagrus auratus", "Coris auricularis", "Chrysophrys auratus", ""], dtype=object)


def _survey(rng: np.random.Generator, n_fish: int):
    """Fish on two videos and one image pair: source, species, time (NaN on the pair), midpoint, length;
    a third of them in tight schools (same time and species, 6–15 cm apart)."""
    source = rng.choice(np.array(["video A", "video B", "pair 3"], dtype=object), n_fish)
    species = rng.choice(SPECIES, n_fish)
    time_s = np.where(source == "pair 3", np.nan, rng.uniform(0, 900, n_fish))
    midpoint = np.column_stack([rng.uniform(-2, 2, n_fish), rng.uniform(-1, 1, n_fish), rng.uniform(1.5, 6, n_fish)])
    for i in range(0, n_fish // 3, 2):  # fish i + 1 schools with fish i
        source[i + 1], species[i + 1], time_s[i + 1] = source[i], species[i], time_s[i]
        direction = rng.normal(size=3)
        midpoint[i + 1] = midpoint[i] + rng.uniform(0.06, 0.15) * direction / np.linalg.norm(direction)
    length = rng.uniform(0.1, 0.8, n_fish)
    return source, species, time_s, midpoint, length


def _reading(rng, fish, survey, offsets, species_override=None) -> ReaderObjects:
    """One reader's objects: the fish ``fish`` (indices) read with their own σ, midpoint noise 5 mm,
    time noise of a few frames, and length offsets (m) added where planted."""
    source, species, time_s, midpoint, length = survey
    n = len(fish)
    sigma = rng.uniform(0.004, 0.03, n)
    read_species = species[fish].copy() if species_override is None else species_override
    return ReaderObjects(ids=np.arange(n) + 1000, source=source[fish], kind=np.full(n, "length", dtype=object),
                         species=read_species, time_s=time_s[fish] + rng.uniform(-0.15, 0.15, n),
                         midpoint=midpoint[fish] + rng.normal(0, 0.005, (n, 3)),
                         value=length[fish] + rng.normal(0, sigma) + offsets, sigma=sigma)


def test_planted_disagreements_and_unmatched_objects_are_found_and_false_alarms_are_near_nominal():
    rng = np.random.default_rng(20261126)
    honest_z, flagged_honest, trials = [], 0, 60
    for _ in range(trials):
        n_fish = int(rng.integers(40, 120))
        survey = _survey(rng, n_fish)
        order = rng.permutation(n_fish)
        only_a, only_b = order[:5], order[5:9]
        wrong_species = order[9:12]  # B names another species: matched on place and time, not as the same fish
        planted = order[12:18]  # B's length off by 7–12 combined σ
        both = order[12:]
        fish_a = np.concatenate([both, only_a, wrong_species])
        fish_b = np.concatenate([both, only_b, wrong_species])
        a = _reading(rng, fish_a, survey, 0.0)
        # B's σ first, so the planted offset can be given in combined σ
        sigma_b = rng.uniform(0.004, 0.03, len(fish_b))
        offsets = np.zeros(len(fish_b))
        combined = np.hypot(a.sigma[:len(planted)], sigma_b[:len(planted)])
        offsets[:len(planted)] = rng.choice([-1, 1], len(planted)) * rng.uniform(7, 12, len(planted)) * combined
        b_species = survey[1][fish_b].copy()
        b_species[-len(wrong_species):] = [SPECIES[(list(SPECIES).index(s) + 1) % len(SPECIES)]
                                           for s in b_species[-len(wrong_species):]]
        source, species, time_s, midpoint, length = survey
        b = ReaderObjects(ids=np.arange(len(fish_b)), source=source[fish_b],
                          kind=np.full(len(fish_b), "length", dtype=object), species=b_species,
                          time_s=time_s[fish_b] + rng.uniform(-0.15, 0.15, len(fish_b)),
                          midpoint=midpoint[fish_b] + rng.normal(0, 0.005, (len(fish_b), 3)),
                          value=length[fish_b] + rng.normal(0, sigma_b) + offsets, sigma=sigma_b)
        # shuffle B's rows: the matching must not lean on the order
        shuffle = rng.permutation(len(b))
        b = ReaderObjects(*(getattr(b, f)[shuffle] for f in ("ids", "source", "kind", "species", "time_s",
                                                             "midpoint", "value", "sigma")))
        report = compare_readers(a, b, tolerance_s=0.5, gate_m=0.04, k=2.0)

        fish_of_a, fish_of_b = fish_a, fish_b[shuffle]
        matched = {(int(fish_of_a[i]), int(fish_of_b[j])) for i, j in report.pairs}
        assert matched == {(int(f), int(f)) for f in both}  # every fish both read, each to itself
        assert set(fish_of_a[report.unmatched_a]) == set(only_a) | set(wrong_species)
        assert set(fish_of_b[report.unmatched_b]) == set(only_b) | set(wrong_species)
        assert {(int(fish_of_a[i]), int(fish_of_b[j])) for i, j in report.species_conflicts} == \
            {(int(f), int(f)) for f in wrong_species}
        is_planted = np.isin(fish_of_a[report.pairs[:, 0]], planted)
        assert np.all(report.flagged[is_planted])  # every planted disagreement is found
        flagged_honest += int(np.sum(report.flagged[~is_planted]))
        honest_z.extend(report.difference[~is_planted] / report.combined_sigma[~is_planted])
        agreement = report.agreement
        assert agreement.n_matched == len(both)
        assert math.isclose(agreement.matched_share, 2 * len(both) / (len(a) + len(b)))
        assert math.isclose(agreement.species_agreement, len(both) / (len(both) + len(wrong_species)))
        assert math.isclose(agreement.share_within_k, 1 - np.mean(report.flagged))
    honest_z = np.array(honest_z)
    nominal = math.erfc(2 / math.sqrt(2))  # P(|z| > 2) = 4.55 %
    rate = flagged_honest / len(honest_z)
    standard_error = math.sqrt(nominal * (1 - nominal) / len(honest_z))
    assert len(honest_z) > 3000
    assert abs(rate - nominal) < 4 * standard_error, (rate, nominal)
    assert abs(np.mean(honest_z ** 2) - 1) < 0.1  # honest σ: mean squared normalised difference near 1


def test_bland_altman_limits_and_shares_follow_the_readers_spread():
    rng = np.random.default_rng(7)
    trials, inside = 200, 0
    for _ in range(trials):
        n = 60
        survey = _survey(rng, n)
        a = _reading(rng, np.arange(n), survey, 0.0)
        b = _reading(rng, np.arange(n), survey, 0.0)
        agreement = compare_readers(a, b, gate_m=0.04).agreement
        spread = np.sqrt(np.mean(a.sigma ** 2 + b.sigma ** 2))  # SD of a − b over these fish
        low, high = agreement.limits
        assert math.isclose(high - low, 2 * LIMITS_Z * agreement.sd_difference)
        assert abs(agreement.sd_difference / spread - 1) < 0.4
        inside += abs(agreement.mean_difference) < 2 * spread / math.sqrt(n)  # unbiased readers
    assert inside / trials > 0.9
    assert agreement.n_matched == n and agreement.matched_share == 1.0


def test_a_constant_bias_of_one_reader_moves_the_mean_difference_not_the_sd():
    rng = np.random.default_rng(11)
    survey = _survey(rng, 400)
    a = _reading(rng, np.arange(400), survey, 0.0)
    b = _reading(rng, np.arange(400), survey, -0.02)  # B reads 2 cm short
    agreement = compare_readers(a, b, gate_m=0.04).agreement
    spread = np.sqrt(np.mean(a.sigma ** 2 + b.sigma ** 2))
    assert abs(agreement.mean_difference - 0.02) < 4 * spread / math.sqrt(400)
    assert abs(agreement.sd_difference / spread - 1) < 0.15


def test_the_nearest_midpoint_wins_and_the_gate_and_tolerance_are_respected():
    def reader(times, points, species=("x",) * 2, source=("v",) * 2):
        n = len(times)
        return ReaderObjects(np.arange(n), list(source), ["length"] * n, list(species), times, points,
                             np.full(n, 0.3), np.full(n, 0.01))

    a = reader([10.0, 10.0], [[0, 0, 2], [0.1, 0, 2]])
    b = reader([10.1, 10.0], [[0.09, 0, 2], [0.01, 0, 2]])
    assert match_objects(a, b, 0.5, 0.05).tolist() == [[0, 1], [1, 0]]
    assert match_objects(a, b, 0.5, 0.005).tolist() == []  # beyond the gate
    late = reader([11.0, 11.0], [[0.09, 0, 2], [0.01, 0, 2]])
    assert match_objects(a, late, 0.5, 0.05).tolist() == []  # another instant
    assert match_objects(a, late, 1.0, 0.05).tolist() == [[0, 1], [1, 0]]
    elsewhere = reader([10.0, 10.0], [[0.09, 0, 2], [0.01, 0, 2]], source=("w", "w"))
    assert match_objects(a, elsewhere, 0.5, 0.05).tolist() == []  # another video
    pair = reader([np.nan, np.nan], [[0, 0, 2], [0.1, 0, 2]])
    assert match_objects(pair, pair, 0.0, 0.05).tolist() == [[0, 0], [1, 1]]  # an image pair: no time
    assert match_objects(pair, a, 0.5, 0.05).tolist() == []  # untimed against timed: not one instant


def test_nothing_to_compare_gives_counts_and_nan_statistics():
    a = ReaderObjects.empty()
    b = ReaderObjects(np.arange(2), ["v", "v"], ["length"] * 2, ["x", "x"], [1.0, 2.0], np.zeros((2, 3)),
                      [0.2, 0.3], [0.01, 0.01])
    report = compare_readers(a, b)
    assert report.pairs.shape == (0, 2) and report.unmatched_b.tolist() == [0, 1]
    assert report.agreement.n_a == 0 and report.agreement.n_b == 2 and report.agreement.matched_share == 0.0
    assert math.isnan(report.agreement.mean_difference) and math.isnan(report.agreement.species_agreement)
    assert math.isnan(compare_readers(a, a).agreement.matched_share)


@pytest.mark.parametrize(("arguments", "name"), [({"k": -1.0}, "k"), ({"k": 0.0}, "k"), ({"gate_m": 0.0}, "gate_m"),
                                                 ({"tolerance_s": math.nan}, "tolerance_s"),
                                                 ({"gate_m": math.inf}, "gate_m")])
def test_bad_parameters_are_named(arguments, name):
    with pytest.raises(InvalidParameterError, match=name):
        compare_readers(ReaderObjects.empty(), ReaderObjects.empty(), **arguments)


def test_bad_arrays_are_named():
    with pytest.raises(InvalidParameterError, match="midpoint"):
        ReaderObjects([1], ["v"], ["length"], ["x"], [0.0], [[0.0, 0.0]], [0.2], [0.01])
    with pytest.raises(InvalidParameterError, match="sigma"):
        ReaderObjects([1], ["v"], ["length"], ["x"], [0.0], [[0.0, 0.0, 1.0]], [0.2], [-0.01])
    with pytest.raises(InvalidParameterError, match="value"):
        ReaderObjects([1], ["v"], ["length"], ["x"], [0.0], [[0.0, 0.0, 1.0]], [math.nan], [0.01])


def test_the_assignment_pairs_the_most_objects_before_the_nearest():
    # a0 is nearest b0 but also within the gate of b1; a1 is within the gate of b0 only
    a = ReaderObjects([0, 1], ["v", "v"], ["length"] * 2, ["x", "x"], [1.0, 1.0], [[0, 0, 2], [0.08, 0, 2]],
                      [0.3, 0.3], [0.01, 0.01])
    b = ReaderObjects([0, 1], ["v", "v"], ["length"] * 2, ["x", "x"], [1.0, 1.0], [[0.03, 0, 2], [-0.06, 0, 2]],
                      [0.3, 0.3], [0.01, 0.01])
    assert match_objects(a, b, 0.5, 0.07).tolist() == [[0, 1], [1, 0]]


def test_the_tolerance_in_frames_pairs_as_the_same_tolerance_in_seconds_over_random_surveys():
    """Frames f = t × fps: a tolerance of N frames pairs exactly what N / fps seconds pairs (times and frames
    kept off the boundary), and what it pairs depends on the frames, not the times."""
    rng = np.random.default_rng(21)
    for _ in range(30):
        fps, n = rng.choice([12.5, 25.0, 30.0]), 40
        survey = _survey(rng, n)
        a, b = (_reading(rng, np.arange(n), survey, np.zeros(n)) for _ in range(2))
        frames = [np.where(np.isnan(r.time_s), np.nan, np.round(r.time_s * fps)) for r in (a, b)]
        a, b = (ReaderObjects(r.ids, r.source, r.kind, r.species, f / fps, r.midpoint, r.value, r.sigma, f)
                for r, f in zip((a, b), frames, strict=True))
        tolerance = int(rng.integers(0, 6))
        by_frames = match_objects(a, b, None, 0.04, tolerance_frames=tolerance)
        assert by_frames.tolist() == match_objects(a, b, (tolerance + 0.5) / fps, 0.04).tolist()
        shuffled_times = [ReaderObjects(r.ids, r.source, r.kind, r.species,
                                        np.where(np.isnan(r.time_s), np.nan, rng.uniform(0, 900, n)),
                                        r.midpoint, r.value, r.sigma, r.frame) for r in (a, b)]
        assert match_objects(*shuffled_times, None, 0.04, tolerance_frames=tolerance).tolist() == by_frames.tolist()
        report = compare_readers(a, b, None, 0.04, 2.0, tolerance_frames=tolerance)
        assert report.pairs.tolist() == by_frames.tolist()


def test_a_video_object_without_a_frame_pairs_with_none_in_frames_and_image_pairs_still_pair():
    def reader(times, frames, source=("v", "p")):
        return ReaderObjects([0, 1], list(source), ["length"] * 2, ["x", "x"], times, [[0, 0, 2], [1, 0, 2]],
                             [0.3, 0.3], [0.01, 0.01], frames)

    a = reader([4.0, np.nan], [100.0, np.nan])
    assert match_objects(a, reader([4.0, np.nan], [101.0, np.nan]), None, 0.05, tolerance_frames=1).tolist() == \
        [[0, 0], [1, 1]]
    assert match_objects(a, reader([4.0, np.nan], [np.nan, np.nan]), None, 0.05, tolerance_frames=9).tolist() == \
        [[1, 1]]  # the video's object has no frame: unmatched; the image pair's objects pair
    assert ReaderObjects.empty().frame.shape == (0,) and np.isnan(reader([1.0, 2.0], None).frame).all()


@pytest.mark.parametrize(("arguments", "words"), [
    ({"tolerance_s": 0.5, "tolerance_frames": 3}, "exactly one of seconds"),
    ({"tolerance_s": None}, "exactly one of seconds"),
    ({"tolerance_s": None, "tolerance_frames": -1}, "tolerance_frames: must be a finite number"),
    ({"tolerance_s": None, "tolerance_frames": math.inf}, "tolerance_frames")])
def test_the_tolerance_is_given_in_exactly_one_of_seconds_or_frames(arguments, words):
    with pytest.raises(InvalidParameterError, match=words):
        compare_readers(ReaderObjects.empty(), ReaderObjects.empty(), **arguments)


def test_an_object_whose_instant_is_unknown_pairs_with_nothing():
    """On a video, neither time nor frame (instant_known False): never paired, whatever the tolerance —
    not even with an object at the start of the video or another without an instant."""
    def reader(times, frames, known):
        return ReaderObjects([0, 1], ["v", "v"], ["length"] * 2, ["x", "x"], times, [[0, 0, 2], [1, 0, 2]],
                             [0.3, 0.3], [0.01, 0.01], frames, known)

    a = reader([np.nan, np.nan], [np.nan, np.nan], [False, False])
    for b in (reader([0.0, 0.0], [0.0, 0.0], [True, True]), reader([np.nan, np.nan], [np.nan, np.nan], [False, False])):
        for tolerance in ({"tolerance_s": 1e6}, {"tolerance_s": None, "tolerance_frames": 1e6}):
            report = compare_readers(a, b, gate_m=5.0, **tolerance)
            assert len(report.pairs) == 0 and report.unmatched_a.tolist() == [0, 1]
            assert report.unmatched_b.tolist() == [0, 1] and len(report.species_conflicts) == 0
    # one of them known on both sides: that one pairs, the other does not
    a, b = reader([1.0, np.nan], [25.0, np.nan], [True, False]), reader([1.0, np.nan], [25.0, np.nan], [True, False])
    assert compare_readers(a, b, 0.5, 5.0).pairs.tolist() == [[0, 0]]
    assert ReaderObjects.empty().instant_known.shape == (0,) and reader([1.0, 2.0], None, None).instant_known.all()


@pytest.mark.parametrize(("a", "b", "agree"), [
    (("Labridae", "", ""), ("Labridae", "", ""), True),
    (("Labridae", "", ""), ("Sparidae", "", ""), False),  # two families: a conflict, no longer '' == ''
    (("Labridae", "", ""), ("Labridae", "Choerodon", "rubescens"), True),  # coarser agrees with finer
    (("Labridae", "Choerodon", ""), ("Labridae", "Choerodon", "rubescens"), True),
    (("Labridae", "Choerodon", "spp"), ("", "Choerodon", "rubescens"), True),  # spp: species not given
    (("Labridae", "Choerodon", "rubescens"), ("Labridae", "Choerodon", "cyanodus"), False),
    (("Labridae", "Choerodon", "rubescens"), ("Labridae", "Coris", "rubescens"), False),
    (("Sparidae", "Pagrus", "auratus"), ("Labridae", "Pagrus", "auratus"), False),
    ((" labridae", "", ""), ("Labridae ", "", ""), True),  # case and spaces ignored
    (("Labridae", "", ""), ("", "Choerodon", "rubescens"), False),  # no level in common
    (("", "", ""), ("", "", ""), True),  # both unidentified
    (("", "", ""), ("Labridae", "", ""), False)])
def test_identifications_agree_on_the_levels_both_give(a, b, agree):
    def reader(taxon):
        return ReaderObjects([0], ["v"], ["length"], ["shown"], [1.0], [[0, 0, 2]], [0.3], [0.01], taxon=[taxon])

    ra, rb = reader(a), reader(b)
    assert taxa_agree(ra.taxon, rb.taxon).tolist() == [[agree]] == taxa_agree(rb.taxon, ra.taxon).T.tolist()
    report = compare_readers(ra, rb, 0.5, 0.1)
    assert len(report.pairs) == int(agree) and len(report.species_conflicts) == int(not agree)
    assert report.agreement.species_agreement == float(agree)


def test_coarser_identifications_pair_and_wrong_ones_conflict_over_random_surveys():
    """Each reader names each fish to a random depth (family; family and genus; or all three): every fish
    both read pairs; a fish B puts in another family (or genus, where both give one) is a conflict."""
    rng = np.random.default_rng(8)
    families = [f"Family{i}" for i in range(4)]
    for _ in range(40):
        n = 30
        survey = _survey(rng, n)
        truth = [(families[i % 4], f"Genus{i % 7}", f"species{i % 11}") for i in rng.integers(0, 1000, n)]

        def coarsened(taxon):
            depth = rng.integers(1, 4)
            return tuple(level if k < depth else "" for k, level in enumerate(taxon))

        taxa_a = [coarsened(t) for t in truth]
        taxa_b = [coarsened(t) for t in truth]
        wrong = rng.choice(n, 4, replace=False)
        for i in wrong:
            family = families[(families.index(truth[i][0]) + 1) % 4]
            taxa_b[i] = (family, *taxa_b[i][1:])
        a = _reading(rng, np.arange(n), survey, np.zeros(n))
        b = _reading(rng, np.arange(n), survey, np.zeros(n))
        a, b = (ReaderObjects(r.ids, r.source, r.kind, r.species, r.time_s, r.midpoint, r.value, r.sigma,
                              taxon=t) for r, t in ((a, taxa_a), (b, taxa_b)))
        report = compare_readers(a, b, 0.5, 0.04)
        # schools: fish i + 1 may swap with fish i, so compare the sets of fish paired and conflicting
        assert set(report.unmatched_a.tolist()) == set(wrong.tolist()) == set(report.unmatched_b.tolist())
        assert len(report.pairs) == n - len(wrong)
        assert set(report.species_conflicts[:, 0].tolist()) == set(wrong.tolist())
        assert report.agreement.species_agreement == pytest.approx((n - len(wrong)) / n)


@pytest.mark.parametrize(("gate_m", "k", "words"), [(0.3, -1.0, "k: must be a finite number > 0"),
                                                    (0.3, 0.0, "k: must be a finite number > 0"),
                                                    (0.0, 2.0, "gate_m: must be a finite number > 0"),
                                                    (float("nan"), 2.0, "gate_m: must be a finite number > 0")])
def test_a_bad_gate_or_k_is_refused_with_the_one_bound_it_has(gate_m, k, words):
    """-1 and 0 get the same words (a negative k was told "≥ 0", and then 0 was told "> 0")."""
    from usvips.core.double_reading import check_parameters

    with pytest.raises(InvalidParameterError, match=words):
        check_parameters(0.5, gate_m, k)
    check_parameters(0.0, 0.3, 2.0)  # a tolerance of 0 is allowed
