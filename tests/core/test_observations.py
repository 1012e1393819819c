"""Stereo observations refuse an id given twice in one pair, and only that."""

import numpy as np
import pytest

from usvips.core.errors import InvalidParameterError
from usvips.core.observations import StereoObservations


def _pixels(n):
    return np.arange(2.0 * n).reshape(n, 2)


@pytest.mark.parametrize("pairs", [(), ("1",) * 5, ("a",) * 5])
def test_an_id_twice_in_one_pair_is_refused(pairs):
    ids = ("p0", "p1", "p2", "p1", "p4")
    with pytest.raises(InvalidParameterError, match="'p1' appears twice in pair"):
        StereoObservations(ids, _pixels(5), _pixels(5), pairs)


def test_the_same_id_in_two_pairs_is_two_points():
    ids = ("p0", "p1", "p0", "p1")
    observations = StereoObservations(ids, _pixels(4), _pixels(4), ("a", "a", "b", "b"))
    assert len(observations) == 4 and observations.pair_labels == ("a", "b")
    with pytest.raises(InvalidParameterError, match="'p0' appears twice in pair 'b'"):
        StereoObservations((*ids, "p0"), _pixels(5), _pixels(5), ("a", "a", "b", "b", "b"))
