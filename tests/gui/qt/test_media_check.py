"""The full check of an opened project's media files in the window (offscreen): it runs in a worker after
the project opens, names a file whose contents changed in a warning that blocks nothing, and stops at
once when the project closes."""

import threading

from PySide6 import QtWidgets

from usvips.app import video_project
from usvips.gui.qt.media_check import media_warning


def _wait_checked(qtbot, window) -> None:
    qtbot.waitUntil(lambda: window.media_check.worker is None and window.media_check.problems is not None
                    and not window.busy, timeout=60000)


def _first_project(qtbot, window, directory):
    """Open a sample once (its project file and media records are made) and let its check finish."""
    assert window.open_path(directory)
    _wait_checked(qtbot, window)
    return window.workspace.project.path


def test_an_unchanged_project_checks_clean_in_the_background(qtbot, make_window, sample_copy):
    window = make_window()
    assert window.open_path(sample_copy("rov_flatport"), "video")
    assert window.media_check.worker is not None  # started on open, in a worker
    _wait_checked(qtbot, window)
    assert window.media_check.problems == []
    assert "not the one added" not in window.statusBar().currentMessage()


def test_a_file_whose_contents_changed_is_named_without_blocking(qtbot, make_window, sample_copy):
    window = make_window()
    path = _first_project(qtbot, window, sample_copy("rov_flatport"))
    records = window.workspace.project.media_records()
    stored, changed, _, _ = records[-1]
    data = bytearray(changed.read_bytes())
    data[len(data) // 2 + 1] ^= 0x01  # one bit, the size kept (a file copied over by another of that size)
    changed.write_bytes(bytes(data))
    assert window.open_path(path, "video")
    _wait_checked(qtbot, window)
    assert [s for s, _ in window.media_check.problems] == [stored]
    box = window.media_check.box
    assert box is not None and box.isVisible() and not box.isModal()  # stays, blocks nothing
    assert QtWidgets.QApplication.activeModalWidget() is None
    assert stored in box.text() and "not the one added" in box.text() and "SHA-256" in box.text()
    assert stored in window.log.toPlainText()  # kept in the log too
    window.video.request(3)  # the window goes on working under the box
    qtbot.waitUntil(lambda: window.workspace.video_frame is not None and window.workspace.video_frame[1] == 3
                    and not window.busy, timeout=10000)
    # opening another project closes the warning of this one
    assert window.open_path(sample_copy("tank_system1"))
    assert window.media_check.box is None


def test_closing_the_project_stops_the_check(qtbot, make_window, sample_copy, monkeypatch):
    """The check of the first project is still reading when another opens: it is cancelled, stops at its
    next block (the real verify_media raising at once) and says nothing; the second is checked."""
    reading = threading.Event()
    stopped = []
    real = video_project.verify_media

    def slow(records, progress=None, cancelled=None):
        if not reading.is_set():
            reading.set()
            while not cancelled():  # the first check "reads" until the window cancels it
                threading.Event().wait(0.01)
            try:
                return real(records, progress, cancelled)
            except video_project.Cancelled:
                stopped.append(True)
                raise
        return real(records, progress, cancelled)

    monkeypatch.setattr(video_project, "verify_media", slow)
    window = make_window()
    assert window.open_path(sample_copy("rov_flatport"), "video")
    first = window.media_check.worker
    qtbot.waitUntil(reading.is_set, timeout=10000)
    assert window.open_path(sample_copy("tank_system1"))
    assert first.is_cancelled and window.media_check.worker is not first
    _wait_checked(qtbot, window)
    assert stopped == [True]  # really stopped, by the real check's own cancel
    assert window.media_check.problems == []
    assert "cancelled" not in window.statusBar().currentMessage()


def test_the_warning_names_the_first_files_and_counts_the_rest():
    problems = [(f"images/{i}.png", "missing (moved or deleted?)") for i in range(5)]
    text = media_warning("dive.usvips", problems)
    assert text.startswith("dive.usvips: 5 media files are not the one added")
    assert "images/0.png: missing" in text and "images/2.png" in text and "images/3.png" not in text
    assert "and 2 more" in text
    assert media_warning("d.usvips", problems[:1]).startswith("d.usvips: a media file is not the one added")
