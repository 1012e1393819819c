"""A rig calibrated from rendered chessboard views, found in image pairs and in a project's stereo video:
phase 1 recovers the true focal lengths and baseline within their standard deviations, phase 2 through a
flat port converges from it, a view the user drops is left out, held-out views validate, and bad input is
one clear line (a pair without the board named and skipped, too few views, a wrong base)."""

from __future__ import annotations

import threading

import cv2
import numpy as np
import pytest

from tests.app.board_images import SIZE, air_scene, board_poses, render_pairs
from usvips.app import board_calibration as boards
from usvips.app.video_project import add_video
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.io.images import write_image
from usvips.io.video_writer import encode_video
from usvips.store import Project

VIEWS = 9


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    folder = tmp_path_factory.mktemp("boards")
    board, rig, air, rng = air_scene(folder, VIEWS)
    water_rig = rig.in_water("flat-port", rng)
    water = render_pairs(folder, water_rig, board, board_poses(water_rig, board, rng, VIEWS, (0.7, 1.0)), "w")
    blank = folder / "blank.png"
    write_image(blank, np.full((SIZE[1], SIZE[0]), 100, np.uint8))
    return {"board": board, "rig": rig, "air": air, "water": water, "blank": blank, "folder": folder}


@pytest.fixture(scope="module")
def air_views(scene):
    return boards.views_from_images(scene["board"], scene["air"] + [(scene["blank"], scene["air"][0][1])])


@pytest.fixture(scope="module")
def air_calibration(scene, air_views):
    return boards.calibrate_views(scene["board"], air_views.views, "air")


def _sigma_errors(calibration, rig) -> list[float]:
    """(estimate − truth) / σ of both focal lengths and of the baseline."""
    out = []
    for name, truth in (("f_l", rig.left.f), ("f_r", rig.right.f)):
        estimate = calibration.parameters[name]
        out.append((estimate.value - truth) / estimate.sigma)
    return out


def test_a_pair_without_the_board_is_named_and_skipped(scene, air_views):
    assert len(air_views.views) == VIEWS
    assert len(air_views.set_aside) == 1
    label, reason = air_views.set_aside[0]
    assert "blank" in reason and "left" in reason
    text = "\n".join(air_views.lines())
    assert f"{VIEWS} of {VIEWS + 1} pairs" in text and "% of the image covered" in text
    counts = air_views.coverage.left.counts
    assert counts.max() <= VIEWS and counts.sum() > 0


def test_phase_one_recovers_the_rig(scene, air_calibration):
    rig = scene["rig"]
    calibration = air_calibration.calibration
    errors = _sigma_errors(calibration, rig)
    assert max(abs(e) for e in errors) < 4.0, errors
    for side, truth in (("left", rig.left.f), ("right", rig.right.f)):
        assert abs(getattr(calibration, side).interior.f / truth - 1) < 0.01
    base = np.linalg.norm(calibration.relative.base)
    assert abs(base / np.linalg.norm(rig.relative.base) - 1) < 0.01
    assert air_calibration.result.report.rms_px < 0.3
    assert air_calibration.lines()[0].startswith("air calibration")
    by_view = air_calibration.view_rms()
    assert set(by_view) == set(air_calibration.kept) and max(by_view.values()) < 0.3
    assert any(line.startswith("  RMS per view, worst first") for line in air_calibration.lines())


def test_a_dropped_view_is_left_out_and_holdout_validates(scene, air_views):
    dropped = air_views.views[2].label
    result = boards.calibrate_views(scene["board"], air_views.views, "air", drop=[dropped], holdout=0.25)
    assert dropped not in result.kept and result.dropped == (dropped,)
    assert dropped not in result.observations.pair_labels
    validation = result.validation
    assert validation is not None and len(validation.held_out.views) >= 1
    assert set(validation.held_out.views).isdisjoint(result.result.report.stations)
    assert validation.held_out.rms_px < 1.0
    text = "\n".join(result.lines())
    assert "held out" in text and "OpenCV" in text
    assert result.result.report.sigma0_px_estimated is not None  # the held-out views judged the sigmas
    # the board's corners robustly estimated, and whether the stated sigmas hold on the held-out views
    assert "robust estimation:" in text and "honesty on held-out views" in text
    honesty = result.validation.as_dict()["honesty"]
    assert honesty["distances"] > 0 and honesty["why"] and result.result.report.estimation["estimator"] == "huber"


def test_phase_two_through_a_flat_port(scene, air_calibration):
    views = boards.views_from_images(scene["board"], scene["water"])
    assert len(views.views) == VIEWS
    result = boards.calibrate_views(scene["board"], views.views, "water", base=air_calibration.calibration,
                                    housing="flat-port")
    assert result.calibration.phase in ("water", "joint")
    assert result.result.report.rms_px < 0.5
    assert result.result.report.housing == "flat-port"


def test_bad_input_is_one_line(scene, air_views, air_calibration):
    board = scene["board"]
    with pytest.raises(InvalidParameterError, match="at least 3"):
        boards.calibrate_views(board, air_views.views[:2], "air")
    with pytest.raises(InvalidParameterError, match="no view is labelled"):
        boards.calibrate_views(board, air_views.views, "air", drop=["nonsense"])
    with pytest.raises(InvalidParameterError, match="base"):
        boards.calibrate_views(board, air_views.views, "water", housing="flat-port")
    with pytest.raises(InvalidParameterError, match="phase"):
        boards.calibrate_views(board, air_views.views, "moon")
    with pytest.raises(InvalidParameterError, match="holdout"):
        boards.calibrate_views(board, air_views.views, "air", holdout=1.5)
    with pytest.raises(UsvipsError, match="none of the 1 pairs.*blank"):
        boards.views_from_images(board, [(scene["blank"], scene["blank"])])
    with pytest.raises(InvalidParameterError, match="images"):
        boards.views_from_images(board, [])


def test_cancel_stops_detection_early(scene):
    seen = []
    stop = threading.Event()

    def progress(fraction, message):
        seen.append(fraction)
        if len(seen) == 3:
            stop.set()

    with pytest.raises(InterruptedError):
        boards.views_from_images(scene["board"], scene["air"], progress=progress, cancel=stop)
    assert len(seen) == 3


def test_views_from_a_project_video_and_storing(scene, tmp_path, air_calibration):
    frames = {"left": [], "right": []}
    for left, right in scene["air"]:
        for side, path in (("left", left), ("right", right)):
            grey = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
            frames[side].append(cv2.cvtColor(grey, cv2.COLOR_GRAY2RGB))
    files = {}
    for side in ("left", "right"):
        files[side] = tmp_path / f"{side}.mkv"
        encode_video(files[side], frames[side], 25.0, "ffv1")
    path = tmp_path / "p.usvips"
    with Project.create(path) as project:
        add_video(project, [files["left"]], [files["right"]], "cal")
        found = boards.views_from_video(project, "cal", scene["board"], every=1)
        assert len(found.views) >= VIEWS - 2  # near-duplicates may go
        assert all(v.label.startswith("cal-") for v in found.views)
        before = len(project.calibrations())
        boards.store(project, air_calibration, "from the board")
        assert len(project.calibrations()) == before + 1


@pytest.mark.slow
def test_monte_carlo_over_rigs_from_rendered_images(tmp_path):
    """Six random rigs, eight rendered board views each, the board found and the rig calibrated by the
    service: the interior's errors over their standard deviations have a mean square near 1 and the
    focal lengths are within 1 %."""
    z = []
    for seed in range(100, 106):
        folder = tmp_path / str(seed)
        folder.mkdir()
        board, rig, pairs, _ = air_scene(folder, 8, seed=seed)
        found = boards.views_from_images(board, pairs)
        assert len(found.views) == 8
        calibration = boards.calibrate_views(board, found.views, "air").calibration
        for name, truth in (("f_l", rig.left.f), ("f_r", rig.right.f), ("xp_l", rig.left.xp), ("yp_l", rig.left.yp),
                            ("k1_l", rig.left.k1)):
            estimate = calibration.parameters[name]
            z.append((estimate.value - truth) / estimate.sigma)
        assert abs(calibration.left.interior.f / rig.left.f - 1) < 0.01
        assert abs(calibration.right.interior.f / rig.right.f - 1) < 0.01
    msne = float(np.mean(np.square(z)))
    assert 0.5 < msne < 2.0, msne
