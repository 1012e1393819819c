"""An object's vertices tracked together (:func:`track_vertices_in_video`): each frame pair decoded once
for all of them, and every track exactly the one its vertex gets alone."""

import numpy as np

from tests.app.test_tracking import FRAMES, survey  # noqa: F401  (the rendered survey fixture)
from usvips.app import tracking
from usvips.app.tracking import track_in_video, track_vertices_in_video
from usvips.io.video_stream import VideoStream
from usvips.store import Project


def test_vertices_tracked_together_equal_each_tracked_alone_with_each_frame_decoded_once(survey, monkeypatch):  # noqa: F811
    path, object_id, _, _, start = survey
    decoded = []
    picture = VideoStream.picture

    def counting(self, index):
        decoded.append(index)
        return picture(self, index)

    with Project.open(path) as project:
        picks = [((v.xl, v.yl), (v.xr, v.yr)) for v in project.object(object_id).vertices]
        alone = [track_in_video(project, "drop", start, left, right, 0, 100) for left, right in picks]
        monkeypatch.setattr(VideoStream, "picture", counting)
        seen = []
        together = track_vertices_in_video(project, "drop", start, picks, 0, 100,
                                           progress=lambda done, total: seen.append(done))
        shared = len(decoded)
        decoded.clear()
        monkeypatch.setattr(tracking, "SHARED_FRAMES_BYTES", 0)  # nothing kept: every vertex decodes again
        track_vertices_in_video(project, "drop", start, picks, 0, 100)
        unshared = len(decoded)
    for one, other in zip(alone, together, strict=True):
        for field in ("frames", "left", "right", "scores", "ray_rms_m"):
            assert np.array_equal(getattr(one, field), getattr(other, field)), field
        assert one.stopped == other.stopped
    assert len(together) == len(picks) == 2 and seen.count(1) == 2  # each vertex's frames reported
    # two cameras, the frames each track reaches (and a frame beyond at each end, read ahead or a stop)
    assert shared <= 2 * (FRAMES + 2) < unshared
