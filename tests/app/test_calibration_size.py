"""A calibration is used only on pictures of its own size: making it active, measuring, synchronising,
taking a frame pair and importing refuse another size with one line naming both sizes."""

from dataclasses import replace

import numpy as np
import pytest

from tests.core.calibration_scenes import FLAT, HEIGHT, WIDTH, rig_at
from usvips.app import calibration_size
from usvips.app.calibration_size import SizeMismatchError, activate, check_size, media_size, size_problem
from usvips.app.pair_geometry import pair_geometry
from usvips.app.project_contents import plan_import, store_import
from usvips.app.video_project import plan_sync, plan_taken_pair
from usvips.core.stereo_calibration import StereoCalibration
from usvips.io.calibration_file import calibration_to_dict, save_calibration
from usvips.io.images import write_image
from usvips.store import Project


def calibration_of(size: tuple[int, int] | None) -> StereoCalibration:
    rig = rig_at(0, FLAT)
    w, h = size if size is not None else (None, None)
    return StereoCalibration.from_cameras(replace(rig.left, width=w, height=h), replace(rig.right, width=w, height=h),
                                          "water", 0.3)


def write_pair(folder, label: str, size: tuple[int, int]) -> tuple:
    paths = []
    for side in ("left", "right"):
        path = folder / f"{label}_{side}.png"
        write_image(path, np.zeros((size[1], size[0]), np.uint8))
        paths.append(path)
    return tuple(paths)


@pytest.fixture
def project(tmp_path):
    with Project.create(tmp_path / "p.usvips") as project:
        project.add_image_pairs([("fits", *write_pair(tmp_path, "fits", (WIDTH, HEIGHT))),
                                 ("cropped", *write_pair(tmp_path, "cropped", (WIDTH - 40, HEIGHT - 40)))],
                                sizes=[(WIDTH, HEIGHT), (WIDTH - 40, HEIGHT - 40)])
        # an older pair whose size was not recorded: read from its left image's header
        project.add_pair("old", *write_pair(tmp_path, "old", (WIDTH // 2, HEIGHT // 2)))
        project.add_pair("bare")  # observations only: no pictures, nothing to compare
        for camera in ("left", "right"):
            (tmp_path / f"{camera}.mp4").write_bytes(b"not decoded here")
        project.add_video("dive", [(tmp_path / "left.mp4", 10, 25.0)], [(tmp_path / "right.mp4", 10, 25.0)],
                          25.0, 10, (1920, 1080))
        yield project


@pytest.mark.parametrize("seed", range(20))
def test_any_other_size_is_named_with_both_sizes_and_the_same_size_passes(seed):
    rng = np.random.default_rng(seed)
    made = (int(rng.integers(100, 5000)), int(rng.integers(100, 4000)))
    calibration = calibration_of(made)
    assert size_problem(calibration, made, "pair 'x'") is None
    other = (made[0] + int(rng.integers(-50, 51)), made[1] + int(rng.integers(1, 51)) * int(rng.choice([-1, 1])))
    line = size_problem(calibration, other, "pair 'x'")
    assert f"{other[0]} × {other[1]} px" in line and f"{made[0]} × {made[1]} px" in line and "pair 'x'" in line
    with pytest.raises(SizeMismatchError, match="pair 'x'"):
        check_size(calibration, other, "pair 'x'")
    # swapped width and height (a portrait frame) is another size too
    if made[0] != made[1]:
        assert size_problem(calibration, made[::-1], "pair 'x'") is not None


def test_a_calibration_without_a_size_or_pictures_without_one_cannot_be_checked_and_passes():
    assert size_problem(calibration_of(None), (640, 480), "pair 'x'") is None
    assert size_problem(calibration_of((640, 480)), None, "pair 'x'") is None


def test_cameras_of_different_sizes_in_one_calibration_are_refused():
    rig = rig_at(0, FLAT)
    odd = StereoCalibration.from_cameras(rig.left, replace(rig.right, width=WIDTH + 2), "water", 0.3)
    with pytest.raises(SizeMismatchError, match="cameras differ in size"):
        calibration_size.calibration_size(odd)


def test_media_sizes_come_from_the_project_then_the_image_header(project):
    assert media_size(project, "fits") == (WIDTH, HEIGHT)
    assert media_size(project, "cropped") == (WIDTH - 40, HEIGHT - 40)
    assert media_size(project, "old") == (WIDTH // 2, HEIGHT // 2)
    assert media_size(project, "dive") == (1920, 1080)
    assert media_size(project, "bare") is None


def test_making_active_refuses_another_size_and_changes_nothing(project):
    calibration_id = project.add_calibration("cal", calibration_to_dict(calibration_of((WIDTH, HEIGHT))))
    activate(project, "fits", calibration_id)
    activate(project, "bare", calibration_id)
    assert project.active_calibration("fits") == calibration_id
    for label, size in (("cropped", f"{WIDTH - 40} × {HEIGHT - 40} px"), ("old", f"{WIDTH // 2} × {HEIGHT // 2} px"),
                        ("dive", "1920 × 1080 px")):
        with pytest.raises(SizeMismatchError, match=f"{label}' is {size} but calibration {calibration_id} was made "
                                                    f"at {WIDTH} × {HEIGHT} px"):
            activate(project, label, calibration_id)
        assert project.active_calibration(label) is None


def test_measuring_refuses_a_pair_made_active_behind_the_checks_back(project):
    calibration_id = project.add_calibration("cal", calibration_to_dict(calibration_of((WIDTH, HEIGHT))))
    project.activate_calibration("cropped", calibration_id)  # the store alone does not check (older projects)
    assert pair_geometry(project, "fits") is None
    project.activate_calibration("fits", calibration_id)
    assert pair_geometry(project, "fits").calibration_id == calibration_id
    with pytest.raises(SizeMismatchError, match=f"pair 'cropped' is {WIDTH - 40} × {HEIGHT - 40} px"):
        pair_geometry(project, "cropped")


def test_synchronising_by_images_names_the_sizes_not_a_folding_distortion(project):
    calibration_id = project.add_calibration("cal", calibration_to_dict(calibration_of((640, 480))))
    job = plan_sync(project, "dive", calibration_id)
    assert job.rig is None
    assert "video 'dive' is 1920 × 1080 px" in job.no_rig and "640 × 480 px" in job.no_rig
    fitting = project.add_calibration("hd", calibration_to_dict(calibration_of((1920, 1080))))
    assert plan_sync(project, "dive", fitting).rig is not None


def test_taking_a_pair_refuses_a_video_whose_active_calibration_does_not_fit(project):
    fitting = project.add_calibration("hd", calibration_to_dict(calibration_of((1920, 1080))))
    project.activate_calibration("dive", fitting)
    assert plan_taken_pair(project, "dive", 3)[0] == "dive-3"
    wrong = project.add_calibration("vga", calibration_to_dict(calibration_of((640, 480))))
    project.activate_calibration("dive", wrong)
    with pytest.raises(SizeMismatchError, match="1920 × 1080 px .* 640 × 480 px"):
        plan_taken_pair(project, "dive", 3)


def test_importing_a_calibration_active_for_a_misfit_stores_nothing(project, tmp_path):
    path = tmp_path / "vga.json"
    save_calibration(calibration_of((640, 480)), path)
    before = len(project.calibrations())
    with pytest.raises(SizeMismatchError, match=r"pair 'fits' is .* but the calibration vga\.json was made at 640"):
        store_import(project, plan_import(calibration=path, active_for=("bare", "fits")))
    assert len(project.calibrations()) == before and project.active_calibration("bare") is None
    store_import(project, plan_import(calibration=path, active_for=("bare",)))
    assert project.active_calibration("bare") is not None
