"""``usvips project review --accept ID@VERSION`` / ``--flag ID@VERSION``: a stamp that is not one is refused
as such (not as a change by someone else), and a stamp that is not the object's version now is refused naming
both stamps — one line, exit 2, nothing written; the stamp --list prints is accepted."""

import numpy as np
import pytest

from usvips.cli import main
from usvips.store.opening import create_project, open_project
from usvips.store.records import Vertex


def _survey(location: str) -> list[int]:
    rng = np.random.default_rng(5)
    with create_project(location) as store:
        store.annotator = "measurer"
        return [store.add_object("point", [Vertex(*map(float, rng.uniform(0, 2000, 4)),
                                                  tuple(map(float, rng.normal(size=3))))], "cod") for _ in range(2)]


def _state(location: str) -> list[tuple[str, int]]:
    with open_project(location, read_only=True) as store:
        return [(r.state, len(store.history(r.object_id))) for r in store.reviews()]


@pytest.mark.parametrize("option", ["--accept", "--flag"])
def test_a_made_up_stamp_is_named_as_not_a_stamp(option, tmp_path, capsys):
    location = str(tmp_path / "r.usvips")
    ids = _survey(location)
    before = _state(location)
    reason = ["--reason", "fin hidden"] if option == "--flag" else []
    capsys.readouterr()
    assert main(["project", "review", location, option, f"{ids[0]}@fake-stamp", *reason]) == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error
    assert "'fake-stamp' is not a version stamp" in error and "last column of --list" in error
    assert "changed by someone else" not in error and _state(location) == before


@pytest.mark.parametrize("option", ["--accept", "--flag"])
def test_a_stamp_that_is_not_the_objects_version_names_both(option, tmp_path, capsys):
    location = str(tmp_path / "r.usvips")
    ids = _survey(location)
    before = _state(location)
    with open_project(location, read_only=True) as store:
        now = store.object(ids[1]).modified
    reason = ["--reason", "fin hidden"] if option == "--flag" else []
    capsys.readouterr()
    assert main(["project", "review", location, option, f"{ids[1]}@2020-01-01T00:00:00+00:00", *reason]) == 2
    error = capsys.readouterr().err.strip()
    assert f"now modified {now}, read at 2020-01-01T00:00:00+00:00" in error
    assert "\n" not in error and _state(location) == before
    assert main(["project", "review", location, option, f"{ids[1]}@{now}", *reason]) == 0  # its own stamp
    assert _state(location)[1][0] == ("accepted" if option == "--accept" else "flagged")


def test_accepting_over_another_reviewers_flag_says_whose_flag_it_replaced(tmp_path, capsys):
    location = str(tmp_path / "r.usvips")
    ids = _survey(location)
    assert main(["project", "review", location, "--flag", str(ids[0]), "--reason", "fork hidden",
                 "--annotator", "bea"]) == 0
    capsys.readouterr()
    assert main(["project", "review", location, "--accept", str(ids[0]), "--annotator", "cid"]) == 0
    out = capsys.readouterr().out
    assert "accepted 1 as cid" in out
    assert f"replaced bea's flag of object {ids[0]} (" in out and "): fork hidden" in out
    assert main(["project", "review", location, "--flag", str(ids[0]), "--reason", "no", "--annotator", "cid"]) == 0
    assert "replaced" not in capsys.readouterr().out  # one's own verdict changed: nothing to say
