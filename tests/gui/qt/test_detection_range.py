"""Measure › Detect fish on a range of frames in a window: the run goes through the window's worker, the
proposals of each fish on the frames become one object with further instants, and the object list shows
each fish's row with its instants counted and the instants' rows as "instant of #N"."""

from PySide6 import QtCore

from tests.app.detection_scenes import make_video_project, scene, write_switching_model
from usvips.gui.qt.detection_dialogs import detect_range


def test_a_range_of_frames_shows_each_fish_once_with_its_instants(qtbot, make_window, tmp_path):
    truth = scene(seed=5)
    path = make_video_project(tmp_path)
    model = write_switching_model(tmp_path, truth, sigma=1.0)
    window = make_window()
    assert window.open_path(path)
    assert window.video.open_video("drop")
    qtbot.waitUntil(lambda: window.workspace.video_frame is not None and not window.busy, timeout=30000)
    context = window.context
    from usvips.gui.qt.detection_dialogs import choose_model

    assert choose_model(context, window, str(model))
    detect_range(context, window, frames=4, every=1)
    qtbot.waitUntil(lambda: not window.busy and len(window.workspace.project.objects()) == 12, timeout=30000)
    qtbot.waitUntil(lambda: len(window.workspace.cache.instant_links()) == 9, timeout=5000)
    table = window.object_list.table.model()

    def texts() -> list[str]:
        return [str(table.index(row, column).data(QtCore.Qt.ItemDataRole.DisplayRole) or "")
                for row in range(table.rowCount()) for column in range(table.columnCount())]

    # each fish's row: its length combined over its 4 instants (figured on the worker)
    qtbot.waitUntil(lambda: sum("(4 instants)" in t for t in texts()) == 3, timeout=20000)
    assert sum(t.startswith("instant of #") for t in texts()) == 9
    # the run's lines reach the log a step a turn of the event loop, after the proposals are stored and shown
    qtbot.waitUntil(lambda: "joined into objects with 9 further instant(s)" in window.log.toPlainText(), timeout=5000)
