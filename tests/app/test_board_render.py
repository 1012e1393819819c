"""Rehearsing a calibration (issue 33, item 6): board views rendered through any housing kind with their
truth; the same seed gives the same views in air and under water; bad values named."""

from __future__ import annotations

import json

import numpy as np
import pytest

from usvips.app.board_render import Rehearsal, housing_pair, render_board_views
from usvips.core import housing as housings
from usvips.core.calibration_targets.kinds.chessboard import Chessboard
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.rig import RelativeOrientation
from usvips.io.images import read_image
from usvips.io.tables import read_observations

SMALL = Rehearsal(views=2, size=(320, 240), supersample=1, distances=(0.9, 1.2), seed=4)


@pytest.fixture(scope="module")
def board():
    return Chessboard(5, 4, 0.04)


@pytest.mark.parametrize("kind", housings.names())
def test_every_housing_kind_renders_views_with_their_truth(tmp_path, board, kind):
    truth = render_board_views(board, tmp_path / "out", kind, plan=SMALL)
    observations = read_observations(tmp_path / "out" / "observations.csv")
    assert observations.pair_labels == ("view_000", "view_001") and len(observations.ids) == 2 * 20
    for side in ("left", "right"):
        image = read_image(tmp_path / "out" / side / "view_001.png")
        assert image.shape[:2] == (240, 320) and image.std() > 10  # a board, not a blank
    assert json.loads((tmp_path / "out" / "truth.json").read_text())["housing"]["kind"] == kind
    assert truth["views"][0]["label"] == "view_000"


def test_the_same_seed_gives_the_same_views_in_air_and_under_water(tmp_path, board):
    air = render_board_views(board, tmp_path / "air", "air", plan=SMALL)
    tank = render_board_views(board, tmp_path / "water", "flat-port", {"g": 0.05}, plan=SMALL)
    for a, w in zip(air["views"], tank["views"], strict=True):
        assert np.allclose(a["board_position"], w["board_position"])
    seen = [read_observations(tmp_path / f / "observations.csv").left for f in ("air", "water")]
    assert not np.allclose(seen[0], seen[1], atol=1.0)  # the refraction moves the pixels


def test_a_stereo_video_and_its_truth(tmp_path, board):
    plan = Rehearsal(views=0, video_frames=4, size=(320, 240), supersample=1, distances=(0.9, 1.2))
    truth = render_board_views(board, tmp_path / "v", "dome-port", plan=plan)
    assert truth["video"]["frames"] == 4 and len(truth["video"]["poses"]) == 4
    assert (tmp_path / "v" / "video_left.avi").stat().st_size > 0 and (tmp_path / "v" / "video_right.avi").exists()
    assert read_observations(tmp_path / "v" / "video_observations.csv").pair_labels[-1] == "video-3"


def test_bad_values_are_named_and_nothing_is_written(tmp_path, board):
    with pytest.raises(InvalidParameterError, match="not a parameter of the flat-port"):
        housing_pair("flat-port", {"q": 1.0}, RelativeOrientation(0.1))
    with pytest.raises(InvalidParameterError, match="tilts"):
        render_board_views(board, tmp_path / "x", plan=Rehearsal(tilts=(50.0, 10.0)))
    with pytest.raises(DegenerateGeometryError, match="does not fit"):
        render_board_views(board, tmp_path / "x", plan=Rehearsal(views=1, size=(320, 240), distances=(0.05, 0.06)))
    assert not (tmp_path / "x").exists()
