"""MaxN from counted observations, against counts made by hand over random surveys."""

import numpy as np
import pytest

from usvips.core.abundance import max_n
from usvips.core.errors import InvalidParameterError


def test_max_n_is_the_largest_per_frame_sum_of_each_group_over_random_surveys():
    rng = np.random.default_rng(4)
    for _ in range(200):
        n = int(rng.integers(1, 60))
        groups = [f"g{g}" for g in rng.integers(0, 4, n)]
        frames = list(rng.integers(0, 6, n))
        numbers = [int(k) for k in rng.integers(1, 5, n)]
        table = np.zeros((4, 6), int)
        for g, f, k in zip(groups, frames, numbers, strict=True):
            table[int(g[1:]), f] += k
        want = {f"g{g}": int(table[g].max()) for g in range(4) if table[g].any()}
        got = max_n(groups, frames, numbers)
        assert got == want and list(got) == list(dict.fromkeys(groups))


def test_bad_observations_are_named():
    with pytest.raises(InvalidParameterError, match="number"):
        max_n(["a"], [0], [0])
    with pytest.raises(InvalidParameterError, match="observations"):
        max_n(["a", "b"], [0], [1])
    assert max_n([], [], []) == {}
