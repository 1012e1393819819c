"""The target path's Qt-free model: pairing by name, what is missing before detection, ticks, and a target
described and written."""

from __future__ import annotations

import json

import pytest

from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.gui.target_session import TargetSession, pair_by_name
from usvips.store import Project


@pytest.fixture()
def project(tmp_path):
    with Project.create(tmp_path / "p.usvips") as p:
        yield p


def test_pairs_follow_the_numbers_in_the_names():
    left = ["c/L10.png", "c/L2.png", "c/L1.png"]
    right = ["c/R1.png", "c/R10.png", "c/R2.png"]
    assert pair_by_name(left, right) == [("c/L1.png", "c/R1.png"), ("c/L2.png", "c/R2.png"),
                                         ("c/L10.png", "c/R10.png")]
    with pytest.raises(InvalidParameterError, match="2 left and 1 right"):
        pair_by_name(left[:2], right[:1])


def test_readiness_names_what_is_missing(project, tmp_path):
    session = TargetSession(project, "water")
    assert session.readiness() == (False, "choose a target file or describe the target")
    session.describe_target({"kind": "chessboard", "cols": 9, "rows": 6, "square": 0.024}, tmp_path / "b.json")
    assert json.loads((tmp_path / "b.json").read_text())["kind"] == "chessboard"
    assert session.readiness() == (False, "choose the left and the right images")
    session.set_images(["L1.png"], ["R1.png"])
    ready, why = session.readiness()
    assert not ready and "phase-1" in why
    session.base_id = 1
    assert session.readiness() == (True, "1 image pairs")
    with pytest.raises(UsvipsError):
        session.calibration_job()  # nothing detected yet
    with pytest.raises(InvalidParameterError, match="no stereo video 'cal'"):
        session.set_video("cal")
    with pytest.raises(InvalidParameterError, match="phase"):
        TargetSession(project, "moon")


def test_a_target_that_contradicts_itself_is_one_line(project, tmp_path):
    session = TargetSession(project, "air")
    with pytest.raises(UsvipsError, match="square"):
        session.describe_target({"kind": "chessboard", "cols": 9, "rows": 6, "square": -1})
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(UsvipsError, match="bad.json"):
        session.load_target(tmp_path / "bad.json")
    assert session.target is None
