"""The target field service on rendered stereo pairs of a 3-D disc field with truth, over random poses and
housings: the found targets are where their discs are, a click under a wrong id is doubtful, targets off
the image are missing, bad clicks are named in one line, and the confirmed targets are stored as the
pair's control observations, which the classic calibration then uses."""

import dataclasses

import numpy as np
import pytest

from tests.app.field_scenes import field_project, stereo_field
from usvips.app import target_field as service
from usvips.core.calibration import CalibrationOptions, calibrate_air
from usvips.core.observations import StereoObservations
from usvips.store.opening import open_project
from usvips.store.records import StaleEditError

CASES = {"air, DLT": ("air", False, 1.8), "air, calibrated": ("air", True, 1.8),
         "flat port, calibrated": ("flat-port", True, 2.6)}


def _search(tmp_path, scene, rng, calibrated, clicks=None, **prepare):
    path, calibration_id = field_project(tmp_path, scene, calibrated=calibrated)
    with open_project(path) as project:
        job = service.prepare(project, "p1", calibration_id=calibration_id if calibrated else None, **prepare)
    result = job.run(clicks or scene.clicks(rng, int(rng.integers(6, 9))))
    return path, result


@pytest.mark.parametrize("case", CASES)
def test_found_targets_are_at_their_discs_and_stored_for_the_calibration(tmp_path, case):
    housing, calibrated, distance = CASES[case]
    rng = np.random.default_rng(list(CASES).index(case) + 300)
    for trial in range(2):
        scene = stereo_field(rng, housing, distance)
        path, result = _search(tmp_path / str(trial), scene, rng, calibrated)
        assert result.role == ("calibration-water" if scene.water else "calibration-air")
        for side in service.SIDES:
            search = result.side(side)
            visible = scene.visible[side]
            good = 0
            for i, pid in enumerate(scene.control.ids):
                target = search.target(pid)
                assert target.status in service.STATUSES and (target.status == "found" or target.reason)
                if target.status == "found":
                    error = np.hypot(*(np.array(target.pixel) - scene.truth[side][i]))
                    assert error < 0.5, (case, trial, side, pid, error)
                    good += bool(visible[i])
            assert good >= 0.9 * visible.sum(), (case, trial, side, search.summary())
        with open_project(path) as project:
            confirmed = service.confirm(project, result)
            stored = project.control_observations(result.role, "p1")
        both = set(result.left.ids("found")) & set(result.right.ids("found"))
        assert confirmed.count == len(both) == len(stored) and set(stored.ids) == both
        for i, pid in enumerate(stored.ids):
            k = scene.control.ids.index(pid)
            assert np.hypot(*(stored.left[i] - scene.truth["left"][k])) < 0.5
            assert np.hypot(*(stored.right[i] - scene.truth["right"][k])) < 0.5


def test_the_stored_targets_calibrate_the_rig_in_air(tmp_path):
    """Phase 1 from the confirmed targets of a pair (the classic calibration's input, one station of a
    3-D field): the rig's baseline within 1 % of the truth."""
    rng = np.random.default_rng(5)
    scene = stereo_field(rng, "air", 1.8)
    path, result = _search(tmp_path, scene, rng, False, clicks=scene.clicks(rng, 8, 1.0))
    with open_project(path) as project:
        service.confirm(project, result)
        stored = project.control_observations("calibration-air", "p1")
        control = project.control()
    assert len(stored) >= 12
    calibration = calibrate_air(control, stored, CalibrationOptions()).calibration
    relative = calibration.relative
    truth = np.linalg.norm(scene.cameras["right"].exterior.position - scene.cameras["left"].exterior.position)
    assert abs(np.linalg.norm([relative.bx, relative.by, relative.bz]) / truth - 1) < 0.01


def test_a_click_under_a_wrong_id_is_doubtful_and_stored_only_when_accepted(tmp_path):
    rng = np.random.default_rng(11)
    scene = stereo_field(rng, "air", 1.8)
    clicks = scene.clicks(rng, 8, 1.0)
    left = scene.visible["left"].copy()
    for pid in clicks["left"]:
        left[scene.control.ids.index(pid)] = False
    real = int(np.flatnonzero(left)[0])  # clicked on this disc, but named as the first clicked target
    wrong = next(iter(clicks["left"]))
    clicks["left"][wrong] = tuple(scene.truth["left"][real] + 0.5)
    path, result = _search(tmp_path, scene, rng, False, clicks=clicks)
    target = result.left.target(wrong)
    assert target.status == "doubtful" and "check its id" in target.reason
    assert result.left.target(scene.control.ids[real]).status == "found"
    with open_project(path) as project:
        service.confirm(project, result)
        assert wrong not in project.control_observations("calibration-air", "p1").ids
    # accepted, it is stored where it was clicked (the user's decision); moved, where it was put
    true_pixel = tuple(scene.truth["left"][scene.control.ids.index(wrong)])
    with open_project(path) as project:
        stored = project.control_observations("calibration-air", "p1")
    result = dataclasses.replace(result, stored=stored)
    with open_project(path) as project:
        service.confirm(project, result, moved={("left", wrong): true_pixel})
        again = project.control_observations("calibration-air", "p1")
    if wrong in result.right.ids("found"):
        k = again.ids.index(wrong)
        assert np.allclose(again.left[k], true_pixel)
    assert len(again) >= len(stored)
    with open_project(path) as project, pytest.raises(service.UsvipsError, match="not doubtful"):
        service.confirm(project, result, accepted={("left", result.left.ids("found")[0])})


def test_targets_off_the_image_are_missing(tmp_path):
    rng = np.random.default_rng(21)
    scene = stereo_field(rng, "air", 1.15)  # near: part of the field is out of the frame
    path, result = _search(tmp_path, scene, rng, False, clicks=scene.clicks(rng, 8, 1.0))
    for side in service.SIDES:
        true = scene.truth[side]
        outside = (true[:, 0] < -0.5) | (true[:, 0] > 319.5) | (true[:, 1] < -0.5) | (true[:, 1] > 239.5)
        assert outside.sum() >= 2
        for i in np.flatnonzero(outside):
            target = result.side(side).target(scene.control.ids[i])
            assert target.status == "missing" and target.reason == "predicted outside the image"


def test_bad_clicks_are_named_in_one_line(tmp_path):
    rng = np.random.default_rng(31)
    scene = stereo_field(rng, "air", 1.8)
    path, _ = field_project(tmp_path, scene)
    with open_project(path) as project:
        job = service.prepare(project, "p1")
    clicks = scene.clicks(rng, 7, 1.0)
    few = {"left": dict(list(clicks["left"].items())[:4]), "right": clicks["right"]}
    cases = [(few, r"left image: 4 targets identified; at least 6 are needed \(2 more\)"),
             ({**clicks, "right": {**clicks["right"], "X9": (10.0, 10.0)}}, "right image: target 'X9' is not a "
              "control point"),
             ({**clicks, "left": {**clicks["left"], "T00": (320.2, 10.0)}}, r"left image: target 'T00' at "
              r"\(320.2, 10\) lies outside the image \(320 × 240 px\)"),
             (scene.clicks(rng, 6, 1.0, planar_only=True), "lie in one plane of the field")]
    for bad, message in cases:
        with pytest.raises(service.ClickError, match=message) as error:
            job.run(bad)
        assert "\n" not in str(error.value)
    # with an earlier calibration, clicks in one plane are enough (the camera is resected)
    path, calibration_id = field_project(tmp_path / "c", scene, calibrated=True)
    with open_project(path) as project:
        calibrated = service.prepare(project, "p1", calibration_id=calibration_id)
    calibrated.check(scene.clicks(rng, 6, 1.0, planar_only=True))


def test_control_from_a_file_and_a_stale_set_refused(tmp_path):
    rng = np.random.default_rng(41)
    scene = stereo_field(rng, "air", 1.8)
    path, _ = field_project(tmp_path, scene, store_control=False)
    with open_project(path) as project:
        with pytest.raises(service.UsvipsError, match="holds no control points"):
            service.prepare(project, "p1")
        with pytest.raises(service.UsvipsError, match="no image pair 'p9'"):
            service.prepare(project, "p9", scene.control)
        job = service.prepare(project, "p1", scene.control)
    result = job.run(scene.clicks(rng, 7, 1.0))
    with open_project(path) as project:
        # someone else stores observations of this pair meanwhile: the confirmation is refused, nothing stored
        other = StereoObservations(("T00",), np.array([[5.0, 5.0]]), np.array([[6.0, 6.0]]), ("p1",))
        project.add_control_observations(other, "calibration-air", "p1")
        with pytest.raises(StaleEditError):
            service.confirm(project, result)
        assert project.control_observations("calibration-air", "p1").ids == ("T00",)
        assert len(project.control()) == 0
    fresh = dataclasses.replace(result, stored=other)
    with open_project(path) as project:
        confirmed = service.confirm(project, fresh)
        assert confirmed.control_stored and len(project.control()) == len(scene.control)
        stored = project.control_observations("calibration-air", "p1")
    assert confirmed.count == len(fresh.observations())
    # the other set's target is replaced when found again, kept otherwise
    assert "T00" in stored.ids and len(stored) == confirmed.count + ("T00" not in fresh.observations().ids)
    with open_project(path) as project, pytest.raises(service.UsvipsError, match="other control points"):
        moved = type(scene.control)(scene.control.ids, scene.control.xyz + 0.01)
        service.prepare(project, "p1", moved)


def test_a_stopped_search_gives_nothing(tmp_path):
    rng = np.random.default_rng(51)
    scene = stereo_field(rng, "air", 1.8)
    path, _ = field_project(tmp_path, scene)
    with open_project(path) as project:
        job = service.prepare(project, "p1")
    clicks = scene.clicks(rng, 7, 1.0)
    asked = []
    fractions = []
    assert job.run(clicks, fractions.append, lambda: asked.append(1) or len(asked) > 40) is None
    # 7 clicks and two rounds of 26 targets are located in the left image: stopped there
    assert len(asked) == 41 and fractions == [0.0]


def test_two_image_files_without_a_project(tmp_path):
    """The service on two image files (no project): through an earlier calibration's cameras under a flat
    port, the targets usable in both images are where their discs are."""
    rng = np.random.default_rng(61)
    scene = stereo_field(rng, "flat-port", 2.5)
    field_project(tmp_path, scene)  # writes the images
    earlier = {side: camera.with_exterior(camera.exterior.with_values(X0=0.0, Y0=0.0)) for side, camera
               in scene.cameras.items()}
    job = service.prepare_images(tmp_path / "p1_left.png", tmp_path / "p1_right.png", scene.control, earlier,
                                 label="tank", medium="water")
    result = job.run(scene.clicks(rng, 7, 1.0))
    observations = result.observations()
    assert result.role == "calibration-water"
    assert result.pair == "tank" and len(observations) >= 10 and set(observations.pairs) == {"tank"}
    for i, pid in enumerate(observations.ids):
        k = scene.control.ids.index(pid)
        assert np.hypot(*(observations.left[i] - scene.truth["left"][k])) < 0.5
        assert np.hypot(*(observations.right[i] - scene.truth["right"][k])) < 0.5


def test_an_underwater_pair_without_a_calibration_is_cautioned(tmp_path):
    rng = np.random.default_rng(71)
    scene = stereo_field(rng, "flat-port", 2.5)
    path, calibration_id = field_project(tmp_path, scene, calibrated=True)
    with open_project(path) as project:
        assert "ignores the refraction" in service.prepare(project, "p1").caution()
        assert service.prepare(project, "p1", calibration_id=calibration_id).caution() == ""
    air = stereo_field(rng, "air", 1.8)
    path, _ = field_project(tmp_path / "air", air)
    with open_project(path) as project:
        assert service.prepare(project, "p1").caution() == ""
