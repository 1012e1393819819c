"""The video navigator's event: a move to another frame is announced once, with the frame."""

from usvips.gui.video_model import VideoNavigator


def test_the_navigator_announces_frame_changes_only():
    nav = VideoNavigator("v", 100, 100, 3, 25.0)
    frames = []
    nav.frame_changed.connect(frames.append)
    nav.go(10)
    nav.go(10)  # no move, no event
    nav.step(5)
    nav.end()
    nav.go(10_000)  # clamped to the last frame: already there
    nav.home()
    assert frames == [10, 15, nav.last, nav.first]
