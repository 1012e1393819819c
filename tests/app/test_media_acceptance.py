"""Accepting changed media files away from the window's thread (usvips.app.media_acceptance): the files read
whole with progress and a cancel, each listed with whether it can stand in for its recording, and the store
taking the file as read — never one changed again since."""

from __future__ import annotations

import pytest

from usvips.app.media_acceptance import accept_changed, find_changed_media, recorded_shapes
from usvips.app.video_project import Cancelled, add_image_pairs, add_video
from usvips.core.errors import InputFileError, UsvipsError
from usvips.core.synth.frame_numbers import numbered_frame
from usvips.io.images import write_image
from usvips.io.video_writer import encode_video
from usvips.store import Project
from usvips.store.records import ProjectError

FPS = 25


def _video(path, frames=12, size=(96, 64), seed=1, fps=FPS):
    encode_video(path, (numbered_frame(i, *size, seed=seed) for i in range(frames)), fps, "h264")


@pytest.fixture
def project(tmp_path):
    """A project with a stereo video (12 frames, 96 × 64 px) and an image pair (80 × 60 px)."""
    for side in ("left", "right"):
        _video(tmp_path / f"{side}.mp4", seed=1 if side == "left" else 2)
        write_image(tmp_path / f"{side}.png", numbered_frame(3, 80, 60, seed=4))
    with Project.create(tmp_path / "p.usvips") as created:
        add_video(created, [tmp_path / "left.mp4"], [tmp_path / "right.mp4"], "v")
        add_image_pairs(created, [("a", tmp_path / "left.png", tmp_path / "right.png")])
    return tmp_path / "p.usvips"


def _changed(project_path):
    with Project.open(project_path) as opened:
        return find_changed_media(opened.media_records(), recorded_shapes(opened))


def test_only_changed_files_are_listed_each_with_whether_it_can_stand_in(project, tmp_path):
    assert _changed(project) == []
    _video(tmp_path / "left.mp4", seed=7)  # a re-export: same frames, rate and size
    _video(tmp_path / "right.mp4", frames=8)  # a shorter export
    write_image(tmp_path / "left.png", numbered_frame(5, 100, 60, seed=4))  # another size
    (tmp_path / "right.png").unlink()  # missing: relocating's business, not accepting's
    changed = {media.stored: media for media in _changed(project)}
    assert set(changed) == {"left.mp4", "right.mp4", "left.png"}
    assert changed["left.mp4"].acceptable
    assert "has 8 frames, but the right chapter of video v had 12" in changed["right.mp4"].refusal
    assert "is 100 × 60 px, but the left image of pair a was 80 × 60 px" in changed["left.png"].refusal
    with Project.open(project) as opened, pytest.raises(InputFileError, match="right.mp4"):
        accept_changed(opened, [changed["left.mp4"], changed["right.mp4"]])  # one refused: none accepted
    assert "left.mp4" in {media.stored for media in _changed(project)}
    with Project.open(project) as opened:
        assert accept_changed(opened, [changed["left.mp4"]]) == ["left.mp4"]
        assert opened.media_identity("left.mp4", full=True) is None
    assert {media.stored for media in _changed(project)} == {"right.mp4", "left.png"}


def test_a_file_changed_again_after_it_was_read_is_not_accepted(project, tmp_path):
    _video(tmp_path / "left.mp4", seed=7)
    [read] = _changed(project)
    _video(tmp_path / "left.mp4", seed=8)  # changed again before the user said yes
    with Project.open(project) as opened:
        with pytest.raises(ProjectError, match="changed again since it was read"):
            accept_changed(opened, [read])
        assert opened.media_identity("left.mp4", full=True) is not None  # nothing recorded anew


def test_a_refusal_after_some_files_were_accepted_names_them(project, tmp_path):
    _video(tmp_path / "right.mp4", seed=7)
    write_image(tmp_path / "left.png", numbered_frame(6, 80, 60, seed=4))
    read = {media.stored: media for media in _changed(project)}
    write_image(tmp_path / "left.png", numbered_frame(7, 80, 60, seed=4))  # changed again before the user said yes
    accepted = []
    with Project.open(project) as opened:
        with pytest.raises(UsvipsError, match="left.png: changed again .*; accepted before it: right.mp4$"):
            accept_changed(opened, [read["right.mp4"], read["left.png"]], accepted)
        assert accepted == ["right.mp4"]  # the caller knows which were taken
        assert opened.media_identity("right.mp4", full=True) is None
        assert opened.media_identity("left.png", full=True) is not None


def test_the_reading_reports_its_progress_and_stops_when_cancelled(project, tmp_path):
    _video(tmp_path / "left.mp4", seed=7)
    with Project.open(project) as opened:
        records, shapes = opened.media_records(), recorded_shapes(opened)
    seen = []
    find_changed_media(records, shapes, lambda done, total: seen.append((done, total)))
    total = sum(path.stat().st_size for _, path, _, _ in records)
    assert seen and seen[-1] == (total, total) and all(a[0] <= b[0] for a, b in zip(seen, seen[1:], strict=False))
    asked = []
    with pytest.raises(Cancelled):
        find_changed_media(records, shapes, cancelled=lambda: asked.append(1) or True)
    assert len(asked) == 1  # stopped at the first block


def test_camera_files_swapped_are_named_and_never_accepted(project, tmp_path):
    """The left and right recordings have the same frames, rate and size: only their contents tell that the
    files were swapped (camera file names repeat across cards), and accepting them would put every left pick
    on the right recording."""
    left, right = tmp_path / "left.mp4", tmp_path / "right.mp4"
    left_bytes, right_bytes = left.read_bytes(), right.read_bytes()
    left.write_bytes(right_bytes)
    right.write_bytes(left_bytes)
    changed = {media.stored: media for media in _changed(project)}
    assert set(changed) == {"left.mp4", "right.mp4"}
    assert not changed["left.mp4"].acceptable and "holds what right.mp4 held" in changed["left.mp4"].refusal
    assert "swapped" in changed["right.mp4"].problem and not changed["right.mp4"].acceptable
    with Project.open(project) as opened, pytest.raises(InputFileError, match="swapped"):
        accept_changed(opened, [changed["left.mp4"]])
