"""The window's Add stereo video stores the medium the user chose (issue 33, item 4): an in-air calibration
video is stored as air, so phase 1's Active for list offers it and phase 2's does not."""

from __future__ import annotations

from usvips.core.synth.frame_numbers import numbered_frame
from usvips.gui.qt import media_dialogs
from usvips.io.video_writer import encode_video


def test_an_in_air_video_is_stored_as_air(qtbot, make_window, tmp_path):
    for side, base in (("left", 0), ("right", 1000)):
        encode_video(tmp_path / f"{side}.mp4", [numbered_frame(base + i) for i in range(8)], 25, "h264", gop=8)
    window = make_window()
    assert media_dialogs.new_project(window.context, window, tmp_path / "mine.usvips")
    media_dialogs.add_video(window.context, window, [tmp_path / "left.mp4"], [tmp_path / "right.mp4"], "cal",
                            medium="air")
    project = window.workspace.project
    qtbot.waitUntil(lambda: "cal" in [p.label for p in project.pairs()], timeout=60000)
    assert {p.label: p.medium for p in project.pairs()} == {"cal": "air"}
