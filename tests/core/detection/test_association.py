"""Proposals of successive frames joined into fish (usvips/core/detection/association.py), against truth over
many random proposal streams (tests/core/detection/fish_streams.py: random rigs and housings, fish swimming
and turning, pairs made to cross in the images or pass close in the water, heavy-tailed keypoint noise,
missed detections, false positives): no chain ever holds two different fish, and at least 90 % of the true
links between successive looked-at frames that both saw the fish are made."""

import numpy as np
import pytest

from tests.core.detection.fish_streams import random_stream
from usvips.core.detection.association import DEFAULT_MAX_SPEED_M_S, Sighting, associate
from usvips.core.errors import InvalidParameterError

CASES = 80


def _score(stream, found):
    """(chains holding two different fish, chains joining a false positive, true links, links made)."""
    mixed = sum(len({stream.fish[i] for i in c} - {-1}) > 1 for c in found.chains)
    false = sum(len(c) > 1 and -1 in {stream.fish[i] for i in c} for c in found.chains)
    following = {a: b for c in found.chains for a, b in zip(c, c[1:], strict=False)}
    position = {f: k for k, f in enumerate(stream.frames)}
    seen = {(o, position[s.frame]): i for i, (s, o) in enumerate(zip(stream.sightings, stream.fish, strict=True))
            if o >= 0}
    true = made = 0
    for (fish, k), i in seen.items():
        j = seen.get((fish, k + 1))
        if j is not None:
            true += 1
            made += following.get(i) == j
    return mixed, false, true, made


def test_over_many_random_streams_no_two_fish_are_joined_and_most_true_links_are_made():
    mixed = false = true = made = sightings = 0
    for case in range(CASES):
        rng = np.random.default_rng(3500 + case)
        stream = random_stream(rng, fish=int(rng.integers(2, 7)), every=int(rng.integers(1, 4)))
        found = associate(stream.sightings, frames=stream.frames)
        assert sorted(i for c in found.chains for i in c) == list(range(len(stream.sightings)))
        for chain in found.chains:  # one sighting a frame, in frame order
            frames = [stream.sightings[i].frame for i in chain]
            assert frames == sorted(set(frames))
        counts = _score(stream, found)
        mixed, false, true, made = (a + b for a, b in zip((mixed, false, true, made), counts, strict=True))
        sightings += len(stream.sightings)
    assert true > 2000 and sightings > 2500
    assert mixed == 0  # never two fish in one chain
    assert made / true >= 0.9, f"{made} of {true} true links made"
    assert false <= 0.002 * sightings  # a false positive is rarely taken for a fish


def _fish(frame, time_s, snout, fork, sigma=0.01):
    return Sighting(frame, time_s, np.array([snout, fork], float), np.tile(np.eye(3) * sigma**2, (2, 1, 1)))


def test_a_fish_faster_than_the_stated_speed_is_not_joined_and_a_slower_one_is():
    start = _fish(0, 0.0, (0, 0, -2), (0.3, 0, -2))
    # 0.1 m in 0.04 s: 2.5 m/s, beyond 1.5 m/s by 0.04 m = 2.8 sigma of the distance (0.014 m): still joined
    # at 3 sigma; 0.15 m is beyond by 0.09 m = 6.4 sigma: not joined
    near, far = _fish(1, 0.04, (0.1, 0, -2), (0.4, 0, -2)), _fish(1, 0.04, (0.15, 0, -2), (0.45, 0, -2))
    assert associate([start, near]).joined == ((0, 1),)
    assert associate([start, far]).joined == ()
    assert associate([start, far], max_speed_m_s=4.0).joined == ((0, 1),)
    assert DEFAULT_MAX_SPEED_M_S == 1.5


def test_two_fish_as_near_as_each_other_are_never_joined_and_counted_apart():
    a0, b0 = _fish(0, 0.0, (0, 0, -2), (0.3, 0, -2)), _fish(0, 0.0, (0, 0.03, -2), (0.3, 0.03, -2))
    a1, b1 = _fish(1, 0.04, (0.01, 0, -2), (0.31, 0, -2)), _fish(1, 0.04, (0.01, 0.03, -2), (0.31, 0.03, -2))
    found = associate([a0, b0, a1, b1])
    assert found.joined == () and found.ambiguous == 2 and len(found.chains) == 4
    # one of them unseen on the next frame: the other is still not taken for either
    found = associate([a0, b0, a1])
    assert found.joined == () and found.ambiguous == 2


def test_a_missed_frame_is_bridged_but_two_are_not():
    seen = [_fish(f, f / 25, (0.02 * f, 0, -2), (0.3 + 0.02 * f, 0, -2)) for f in (0, 2, 5)]
    found = associate(seen, frames=range(6))
    assert found.chains == ((0, 1), (2,))
    assert associate(seen, frames=range(6), max_missed=2).chains == ((0, 1, 2),)


@pytest.mark.parametrize("change,words", [
    (dict(max_speed_m_s=0.0), "max_speed"),
    (dict(max_missed=-1), "max_missed"),
    (dict(frames=[1, 0]), "increasing"),
    (dict(frames=[0]), "not among the frames"),
])
def test_bad_parameters_are_named(change, words):
    seen = [_fish(0, 0.0, (0, 0, -2), (0.3, 0, -2)), _fish(1, 0.04, (0, 0, -2), (0.3, 0, -2))]
    with pytest.raises(InvalidParameterError, match=words):
        associate(seen, **change)


def test_a_later_frame_at_an_earlier_time_and_a_degenerate_covariance_are_refused():
    with pytest.raises(InvalidParameterError, match="later"):
        associate([_fish(0, 0.1, (0, 0, -2), (0.3, 0, -2)), _fish(1, 0.1, (0, 0, -2), (0.3, 0, -2))])
    with pytest.raises(InvalidParameterError, match="positive definite"):
        associate([_fish(0, 0.0, (0, 0, -2), (0.3, 0, -2), 0.0), _fish(1, 0.04, (0.1, 0, -2), (0.3, 0, -2), 0.0)])
    with pytest.raises(InvalidParameterError, match="finite"):
        _fish(0, float("nan"), (0, 0, -2), (0.3, 0, -2))
