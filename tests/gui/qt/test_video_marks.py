"""The video timeline's marks (the frames holding measured objects) follow each change of the objects from
the window's object cache, never by reading every stored object again: a detection run tells its proposals
a slice a turn, and each read grew with the survey."""

from usvips.store.records import Vertex


def test_the_timelines_marks_follow_a_change_from_the_objects_held(qtbot, make_window, sample_copy, monkeypatch):
    window = make_window()
    assert window.open_path(sample_copy("rov_flatport"), "video")
    qtbot.waitUntil(lambda: window.workspace.video_frame is not None and not window.busy, timeout=10000)
    ws = window.workspace
    vertices = [Vertex(300.0 + k, 200.0, 280.0 + k, 200.0, pair=ws.pair, video="video", frame_left=7, frame_right=10,
                       time_s=0.7) for k in range(2)]
    new = ws.project.add_object("length", vertices)
    read = []
    objects = ws.project.objects
    monkeypatch.setattr(ws.project, "objects", lambda: read.append(True) or objects())
    ws.objects_changed_in_store(added=(new,))
    assert 7 in window.video.navigator.marks and 7 in window.video.dock_widget.timeline.marks
    assert not read
