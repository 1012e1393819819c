"""Schema 4: videos with their files and offset, periods, and the frames and time of each vertex; an
older project migrates to it and keeps its contents."""

import dataclasses
import shutil
from pathlib import Path

import pytest

from usvips.store import Project
from usvips.store.project import ProjectError, Vertex
from usvips.store.records import VideoFile
from usvips.store.schema import SCHEMA_VERSION

DATA = Path(__file__).parent / "data"


@pytest.fixture
def project(tmp_path):
    media = tmp_path / "media"
    media.mkdir()
    for name in ("l1.mp4", "l2.mp4", "r1.mp4"):
        (media / name).write_bytes(name.encode() * 100)
    with Project.create(tmp_path / "p.usvips") as p:
        p.add_video("dive", [(media / "l1.mp4", 60, 30.0), (media / "l2.mp4", 40, 30.0)],
                    [(media / "r1.mp4", 100, 30.0)], 30.0, 100, (1920, 1080), "")
        yield p


def test_a_video_keeps_its_files_in_order_and_its_offset(project):
    video = project.video("dive")
    assert video.paths("left") == ["media/l1.mp4", "media/l2.mp4"] and video.paths("right") == ["media/r1.mp4"]
    assert (video.frame_count, video.fps, video.width, video.offset_frames) == (100, 30.0, 1920, 0)
    project.set_video_offset("dive", -12, {"method": "flash", "confidence": 0.9})
    assert project.video("dive").offset_frames == -12
    assert project.video("dive").offset_estimate["method"] == "flash"
    for bad in (100, -100, 2.5):
        with pytest.raises(ProjectError, match="not a whole number smaller than the video"):
            project.set_video_offset("dive", bad)
    with pytest.raises(ProjectError, match="label already used"):
        project.add_video("dive", [(project.path.parent / "media" / "l1.mp4", 1, 30.0)], [], 30.0, 1, (1, 1))
    assert [v.label for v in project.videos()] == ["dive"]


def test_a_video_is_a_frozen_record_with_each_cameras_chapters(project):
    """The store returns a :class:`Video` (no dict): each camera's chapter files with their frame counts and
    frame rates, read only."""
    video = project.video("dive")
    assert video.files("left") == (VideoFile("media/l1.mp4", 60, 30.0), VideoFile("media/l2.mp4", 40, 30.0))
    assert video.right == (VideoFile("media/r1.mp4", 100, 30.0),) and video.report == "" and video.height == 1080
    assert video.offset_estimate is None and project.videos() == [video]
    with pytest.raises(dataclasses.FrozenInstanceError):
        video.offset_frames = 3
    with pytest.raises(ValueError, match="'left' or 'right'"):
        video.files("middle")


def test_periods_and_vertex_frames_round_trip(project):
    project.add_period("dive", "bait", 10, 40)
    project.add_period("dive", "arrival", 0, 9)
    assert project.periods("dive") == [("arrival", 0, 9), ("bait", 10, 40)]
    for start, end in ((5, 3), (-1, 4), (90, 100)):
        with pytest.raises(ProjectError, match="not an interval within the video"):
            project.add_period("dive", "x", start, end)
    vertices = [Vertex(1, 2, 3, 4, (0.1, 0.2, -1.5), None, None, None, "dive", 20, 32, 0.6667),
                Vertex(5, 6, 7, 8, None, None, None, None, "dive", 20, 32, 0.6667)]
    object_id = project.add_object("line", vertices, "Pagrus auratus")
    back = project.object(object_id).vertices
    assert [(v.video, v.frame_left, v.frame_right, v.time_s) for v in back] == [("dive", 20, 32, 0.6667)] * 2
    moved = [Vertex(1, 2, 3, 4, None, None, None, None, "dive", 21, 33, 0.7)]
    project.update_object(object_id, vertices=moved)
    assert project.object(object_id).vertices[0].frame_left == 21
    with pytest.raises(ProjectError, match="needs its left and right frames"):
        project.add_object("point", [Vertex(1, 2, 3, 4, video="dive")])
    project.delete_object(object_id)
    assert project._db.execute("SELECT COUNT(*) FROM vertex_frames").fetchone()[0] == 0


def test_an_older_project_migrates_to_schema_4_and_keeps_its_contents(tmp_path):
    path = tmp_path / "old.usvips"
    shutil.copy(DATA / "project_v1.usvips", path)
    with Project.open(path) as p:
        assert p.version == SCHEMA_VERSION >= 4
        before = [o.attribute for o in p.objects()]
        assert before and p.videos() == [] and p.media_problems() == []
        p.add_object("point", [Vertex(1, 2, 3, 4)])
    with Project.open(path) as p:
        assert [o.attribute for o in p.objects()][:-1] == before
