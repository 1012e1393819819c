"""Opening another project leaves nothing of the previous one on screen: the video dock's offset, frame,
range and typed go-to are new controls; the pair box follows what the panes show; the X/Y/Z readout is
gone. And a video's frames show as "(video)" in the pair box, an image pair by its label."""

from tests.gui.test_video_window import _wait_frame


def test_a_second_project_starts_with_fresh_video_controls_and_readouts(qtbot, make_window, sample_copy):
    window = make_window()
    rov = sample_copy("rov_flatport")
    assert window.open_path(rov, "video")
    _wait_frame(qtbot, window, 0)
    window.video.request(12)
    _wait_frame(qtbot, window, 12)
    first = window.video.dock_widget
    first.goto.setText("00:01.000")
    first.jump.setValue(25)
    assert window.pair_box.currentIndex() == -1 and window.pair_box.placeholderText() == "(video)"
    assert first.offset.value() != 0 and "left 12" in first.frame_label.text()
    window.point_label.setText("X 1.0000  Y 2.0000  Z 3.0000 m")  # a readout left from a measurement
    assert window.open_path(sample_copy("tank_system1"))
    qtbot.waitUntil(lambda: window.workspace.pair is not None and not window.busy, timeout=10000)
    d = window.video.dock_widget
    assert d is not first and window.docks["video"].widget() is d
    assert (d.offset.value(), d.frame_label.text(), d.goto.text(), d.jump.value()) == (0, "—", "", 10)
    assert d.timeline.marks == set() and d.chooser.count() == 0 and not d.isEnabled()
    assert window.point_label.text() == ""
    assert window.pair_box.currentText() == window.workspace.pair and window.pair_box.currentIndex() >= 0
    # back to the video project: its own offset again, the new dock wired to the controller
    assert window.open_path(rov, "video")
    _wait_frame(qtbot, window, 0)
    d = window.video.dock_widget
    assert d.offset.value() == window.workspace.project.video("video").offset_frames
    d.goto.setText("5")
    d.goto.returnPressed.emit()
    _wait_frame(qtbot, window, 5)
    assert "left 5" in d.frame_label.text()


def test_coming_back_to_a_project_shows_the_pair_or_video_frame_left(qtbot, make_window, sample_copy, tmp_path):
    """The pair last shown was remembered only when the window closed, and never a video's frame: coming
    back from another project showed the first image pair."""
    from usvips.store import Project

    window = make_window()
    rov = sample_copy("rov_flatport")
    other = tmp_path / "other.usvips"
    Project.create(other).close()
    assert window.open_path(rov, "video")
    _wait_frame(qtbot, window, 0)
    window.video.request(7)
    _wait_frame(qtbot, window, 7)
    assert window.open_path(other) and window.workspace.pair is None
    assert window.open_path(rov)
    _wait_frame(qtbot, window, 7)  # the video, on the frame left
    window.load_pair("water2")
    qtbot.waitUntil(lambda: window.workspace.pair == "water2" and not window.busy, timeout=10000)
    assert window.open_path(other) and window.open_path(rov)
    qtbot.waitUntil(lambda: window.workspace.pair == "water2" and not window.busy, timeout=10000)
    assert window.workspace.video_frame is None and window.video.navigator is None
