"""Work mapped over a stream on worker processes: the results in the stream's order, and a worker's
failure raised as the plain loop raises it."""

import pytest

from usvips.app.ordered_pool import ordered_map
from usvips.core.errors import InvalidParameterError


def _scaled(state, item):
    if item == state["bad"]:
        raise InvalidParameterError("item", f"{item} is refused")  # an error whose class takes two arguments
    return state["factor"] * item


@pytest.mark.parametrize("workers", [1, 2, 3])
@pytest.mark.parametrize("ahead", [1, 2, 5])
def test_the_results_come_in_the_streams_order(workers, ahead):
    items = list(range(40))
    given = list(ordered_map(_scaled, {"factor": 3, "bad": None}, iter(items), workers, ahead))
    assert given == [(i, 3 * i) for i in items]


@pytest.mark.parametrize("bad", [0, 1, 17])
def test_a_failure_in_a_worker_is_the_plain_loops_error(bad):
    state = {"factor": 2, "bad": bad}
    with pytest.raises(InvalidParameterError) as plain:
        list(ordered_map(_scaled, state, range(30), workers=1))
    given = []
    with pytest.raises(InvalidParameterError) as pooled:
        for item, result in ordered_map(_scaled, state, range(30), workers=2):
            given.append((item, result))
    assert str(pooled.value) == str(plain.value) and f"{bad} is refused" in str(plain.value)
    assert given == [(i, 2 * i) for i in range(bad)]


def test_an_empty_stream_gives_nothing():
    assert list(ordered_map(_scaled, {"factor": 1, "bad": None}, [], workers=2)) == []
