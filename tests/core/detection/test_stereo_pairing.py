"""Stereo pairing of detections through the housing and their lengths, by Monte Carlo over random rigs of
every housing kind: fish as 3-D snout/fork pairs imaged with pixel noise, distractors and missed detections.
The assignment recovers the true pairs where they are unambiguous, leaves a fish whose partner was missed
unpaired, and the lengths' sigmas for the given keypoint sigma have a mean squared normalised error near 1."""

import numpy as np
import pytest

from tests.core.detection.stereo_scenes import NAMES, random_calibration, random_frame
from usvips.core import housing as housings
from usvips.core.detection import Detection, Keypoint
from usvips.core.detection.stereo import (
    STATED_KEYPOINT_SIGMA,
    assign,
    curve_distances,
    epipolar_curves,
    measure_pairs,
    pair_detections,
    pairing_costs,
)
from usvips.core.errors import InvalidParameterError
from usvips.core.matching import epipolar_curve
from usvips.core.measurements.evaluate import Measurement

FRAMES_PER_KIND = 12


def _gate(frame) -> float:
    """4 sigma of a keypoint's distance to its partner's curve (noise on both sides)."""
    return 4.0 * np.sqrt(2.0) * max(frame.sigma.values())


def monte_carlo(kind: str, rng: np.random.Generator, frames: int = FRAMES_PER_KIND) -> dict:
    """Over ``frames`` random rigs of ``kind``: how many detections' pairing was decidable (no rival within
    the gate), how many of those the assignment decided right, the pairs made and the wrong ones among them,
    and the normalised squared errors of the correctly paired lengths."""
    decided, right_decisions, nees, wrong_pairs, pairs_made = 0, 0, [], 0, 0
    for _ in range(frames):
        calibration = random_calibration(rng, kind)
        frame = random_frame(rng, calibration)
        rig, gate = calibration.rig(0, "object"), _gate(frame)
        pairing = pair_detections(frame.left, frame.right, rig, gate_px=gate)
        made = {(p.left_index, p.right_index) for p in pairing.pairs}
        costs = pairing_costs(frame.left, frame.right, rig)
        pairs_made += len(made)
        wrong_pairs += sum(frame.left_fish[i] != frame.right_fish[j] or frame.left_fish[i] < 0 for i, j in made)
        for i, fish in enumerate(frame.left_fish):
            if fish < 0:
                continue
            partner = frame.right_fish.index(fish) if fish in frame.right_fish else None
            rivals = [j for j in range(len(frame.right)) if j != partner and costs[i, j] < gate]
            if partner is not None:
                rivals += [k for k in range(len(frame.left)) if k != i and costs[k, partner] < gate]
            if rivals or (partner is not None and costs[i, partner] >= gate):
                continue  # ambiguous: another detection lies within the gate, or noise pushed the partner out
            decided += 1
            if partner is None:
                right_decisions += i in pairing.unpaired_left
            else:
                right_decisions += (i, partner) in made
        correct = [p for p in pairing.pairs if frame.left_fish[p.left_index] == frame.right_fish[p.right_index] >= 0]
        for pair, measured in zip(correct, measure_pairs(correct, calibration, frame.sigma), strict=True):
            assert isinstance(measured, Measurement), measured
            assert STATED_KEYPOINT_SIGMA in measured.marks and measured.pointing_origin == "given"
            truth = frame.fish[frame.left_fish[pair.left_index]]
            length = measured.main
            nees.append(((length.value - np.linalg.norm(truth[1] - truth[0])) / length.sigma) ** 2)
    return {"decided": decided, "right": right_decisions, "pairs": pairs_made, "wrong": wrong_pairs,
            "nees": np.array(nees)}


@pytest.mark.parametrize("kind", housings.names())
def test_pairs_are_recovered_and_lengths_have_honest_sigmas(kind):
    found = monte_carlo(kind, np.random.default_rng(sum(map(ord, kind))))
    decided, right_decisions, nees = found["decided"], found["right"], found["nees"]
    wrong_pairs, pairs_made = found["wrong"], found["pairs"]
    assert decided > 0.6 * FRAMES_PER_KIND * 8
    assert right_decisions / decided >= 0.99, (right_decisions, decided)
    assert wrong_pairs <= 0.03 * pairs_made, (wrong_pairs, pairs_made)
    assert len(nees) > 0.6 * FRAMES_PER_KIND * 8
    assert 0.7 <= np.mean(nees) <= 1.5, (np.mean(nees), len(nees))


def test_the_batched_curves_are_the_matching_modules_curves():
    rng = np.random.default_rng(4)
    rig = random_calibration(rng, "dome-port").rig(0, "object")
    pixels = np.array([[300.0, 200.0], [900.5, 700.25], [640.0, 480.0]])
    curves, ok = epipolar_curves(rig.left, rig.right, pixels, 0.5, 6.0, 120)
    targets = rng.uniform(100, 1100, (5, 2))
    distances = curve_distances(curves, ok, targets)
    for n, pixel in enumerate(pixels):
        one = epipolar_curve(rig.left, rig.right, pixel, 0.5, 6.0, 120)
        np.testing.assert_allclose(curves[n][ok[n]], one.pixels)
        np.testing.assert_allclose(distances[n], [one.distance_to(t) for t in targets], rtol=1e-9, atol=1e-9)


def _fish(points, class_name="fish", names=NAMES, confidence=0.9):
    points = np.asarray(points, float)
    return Detection((*points.min(axis=0), *points.max(axis=0)), class_name, 0.9,
                     tuple(Keypoint(n, *p, confidence) for n, p in zip(names, points, strict=True)))


def test_different_classes_low_confidence_and_no_common_keypoint_cannot_pair():
    rng = np.random.default_rng(8)
    calibration = random_calibration(rng, "flat-port")
    rig = calibration.rig(0, "object")
    frame = random_frame(rng, calibration, fish=1, distractors=0, missed=0.0)
    left, right = frame.left[0], frame.right[0]
    points = lambda d: [k.pixel for k in d.keypoints]  # noqa: E731
    assert np.isfinite(pairing_costs([left], [right], rig)[0, 0])
    assert np.isinf(pairing_costs([left], [_fish(points(right), "shark")], rig)[0, 0])
    assert np.isinf(pairing_costs([left], [_fish(points(right), names=("a", "b"))], rig)[0, 0])
    assert np.isinf(pairing_costs([left], [_fish(points(right), confidence=0.1)], rig, min_confidence=0.5)[0, 0])
    pairing = pair_detections([left], [_fish(points(right), "shark")], rig)
    assert pairing.pairs == () and pairing.unpaired_left == (0,) and pairing.unpaired_right == (0,)
    assert pair_detections([], [right], rig).unpaired_right == (0,)


def test_a_pair_beyond_the_gate_is_not_made():
    rng = np.random.default_rng(9)
    calibration = random_calibration(rng, "dome-cover")
    rig = calibration.rig(0, "object")
    frame = random_frame(rng, calibration, fish=1, distractors=0, missed=0.0)
    cost = pairing_costs(frame.left, frame.right, rig)[0, 0]
    assert len(pair_detections(frame.left, frame.right, rig, gate_px=cost * 1.01).pairs) == 1
    assert pair_detections(frame.left, frame.right, rig, gate_px=cost * 0.99).pairs == ()


def test_measuring_needs_each_keypoint_and_its_sigma():
    rng = np.random.default_rng(10)
    calibration = random_calibration(rng, "air")
    frame = random_frame(rng, calibration, fish=2, distractors=0, missed=0.0)
    pairs = pair_detections(frame.left, frame.right, calibration.rig(0, "object"), gate_px=_gate(frame)).pairs
    assert len(pairs) == 2
    with pytest.raises(InvalidParameterError, match="no pointing sigma given for keypoint 'fork'"):
        measure_pairs(pairs, calibration, {"snout": 1.0})
    with pytest.raises(InvalidParameterError, match="keypoint_sigma_px"):
        measure_pairs(pairs, calibration, -1.0)
    results = measure_pairs(pairs, calibration, 1.0, keypoints=("snout", "tail"))
    assert all(isinstance(r, InvalidParameterError) and "no keypoint 'tail'" in str(r) for r in results)
    one = measure_pairs(pairs, calibration, {"snout": 0.5, "fork": 2.0})[0]
    np.testing.assert_allclose(one.pointing_sigma_px.reshape(2, -1)[:, 0], [0.5, 2.0])


def test_the_assignment_is_global_not_greedy_and_respects_the_gate():
    # greedy takes (0, 0) at 1 px and leaves row 1 unpaired (its only candidate is taken); the assignment
    # pairs both rows at 2 + 1.5 px
    costs = np.array([[1.0, 2.0], [1.5, np.inf]])
    assert sorted(assign(costs, 3.0)) == [(0, 1), (1, 0)]
    assert assign(costs, 1.2) == [(0, 0)]  # beyond the gate a pair is not made
    assert assign(np.full((2, 3), np.inf), 3.0) == [] and assign(np.zeros((0, 4)), 3.0) == []


def test_curves_need_a_depth_range_and_samples():
    rig = random_calibration(np.random.default_rng(12), "air").rig(0, "object")
    with pytest.raises(InvalidParameterError, match="parameter far"):
        epipolar_curves(rig.left, rig.right, [[600.0, 400.0]], near=2.0, far=1.0)
    with pytest.raises(InvalidParameterError, match="parameter samples"):
        epipolar_curves(rig.left, rig.right, [[600.0, 400.0]], samples=1)
    with pytest.raises(InvalidParameterError, match="parameter gate_px"):
        pair_detections([], [], rig, gate_px=0.0)
