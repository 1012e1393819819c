"""File › Accept changed media… in the window (offscreen): the changed files are read in a worker, listed
with how each differs and whether it can stand in for its recording, nothing ticked at first, and only a
ticked file that can stand in is taken as the recording."""

from pathlib import Path

import shiboken6
from PySide6 import QtCore, QtWidgets

from usvips.app.media_acceptance import ChangedMedia
from usvips.gui.qt import media_dialogs
from usvips.gui.qt.accept_media_dialog import AcceptMediaDialog


def _changed(stored: str, refusal: str = "") -> ChangedMedia:
    return ChangedMedia(stored, Path("/nowhere") / stored, "its contents differ from the file added (SHA-256; same "
                        "size)", refusal, "0" * 64, (10, "1" * 64, "2" * 64))


def test_the_dialog_ticks_nothing_at_first_and_never_a_file_that_cannot_stand_in(qtbot):
    dialog = AcceptMediaDialog([_changed("left.mp4"), _changed("right.mp4", "has 8 frames, but the right chapter of "
                                                                             "video v had 12")])
    qtbot.addWidget(dialog)
    dialog.show()
    qtbot.waitExposed(dialog)
    assert dialog.chosen() == [] and not dialog.accept_button.isEnabled()
    refused = dialog.files.item(1)
    assert not refused.flags() & QtCore.Qt.ItemFlag.ItemIsEnabled
    assert "\n    cannot stand in: has 8 frames" in refused.text()
    dialog.files.setFocus()
    dialog.files.setCurrentRow(0)
    qtbot.keyClick(dialog.files, QtCore.Qt.Key.Key_Space)  # ticked by the keyboard
    assert [m.stored for m in dialog.chosen()] == ["left.mp4"] and dialog.accept_button.isEnabled()
    refused.setCheckState(QtCore.Qt.CheckState.Checked)  # even ticked by force, it is not chosen
    assert [m.stored for m in dialog.chosen()] == ["left.mp4"]
    qtbot.keyClick(dialog.files, QtCore.Qt.Key.Key_Space)
    assert dialog.chosen() == [] and not dialog.accept_button.isEnabled()
    qtbot.keyClick(dialog.files, QtCore.Qt.Key.Key_Return)  # nothing ticked: Enter accepts nothing
    assert dialog.isVisible() and dialog.result() != QtWidgets.QDialog.DialogCode.Accepted
    qtbot.keyClick(dialog.files, QtCore.Qt.Key.Key_Space)
    qtbot.keyClick(dialog.files, QtCore.Qt.Key.Key_Tab)  # Tab goes to Accept (not Cancel), Enter presses it
    assert dialog.focusWidget() is dialog.accept_button
    qtbot.keyClick(dialog.accept_button, QtCore.Qt.Key.Key_Return)
    assert dialog.result() == QtWidgets.QDialog.DialogCode.Accepted and not dialog.isVisible()
    assert [m.stored for m in dialog.chosen()] == ["left.mp4"]


def test_a_changed_video_is_accepted_from_the_window_after_it_is_read_in_a_worker(qtbot, make_window, sample_copy):
    window = make_window()
    assert window.open_path(sample_copy("rov_flatport"), "video")
    qtbot.waitUntil(lambda: window.media_check.problems is not None and not window.busy, timeout=60000)
    labels = [a.text() for a in window.menuBar().actions()[0].menu().actions()]
    assert "Accept c&hanged media…" in labels
    project = window.workspace.project
    media_dialogs.accept_changed_media(window.context, window, answers=set())
    qtbot.waitUntil(lambda: not window.busy, timeout=60000)
    assert "no media file has changed" in window.statusBar().currentMessage()
    stored, changed, _, _ = project.media_records()[-1]
    data = bytearray(changed.read_bytes())
    data[len(data) // 2 + 1] ^= 0x01  # a repaired copy: same size, same frames, other bytes
    changed.write_bytes(bytes(data))
    media_dialogs.accept_changed_media(window.context, window, answers=set())  # found, none chosen
    qtbot.waitUntil(lambda: not window.busy, timeout=60000)
    assert "1 changed media file found; none accepted" in window.statusBar().currentMessage()
    assert project.media_identity(stored, full=True) is not None
    media_dialogs.accept_changed_media(window.context, window, answers={stored})
    assert window.busy  # the files are read in a worker
    qtbot.waitUntil(lambda: not window.busy, timeout=60000)
    assert f"accepted {stored}" in window.statusBar().currentMessage()
    assert project.media_identity(stored, full=True) is None


def test_the_media_warning_offers_to_accept_a_changed_file(qtbot, make_window, sample_copy, monkeypatch):
    """The warning box of the media check has an Accept changed media… button (a changed file, not only a
    missing one); it reads the files and lists the changed one in the dialog."""
    from usvips.gui.qt import accept_media_dialog

    listed = []

    def shown(dialog):  # the modal dialog, answered at once: cancelled
        listed.append([media.stored for media in dialog.changed])
        return QtWidgets.QDialog.DialogCode.Rejected

    monkeypatch.setattr(accept_media_dialog.AcceptMediaDialog, "exec", shown)
    directory = sample_copy("rov_flatport")
    window = make_window()
    assert window.open_path(directory, "video")
    qtbot.waitUntil(lambda: window.media_check.problems is not None and not window.busy, timeout=60000)
    path = window.workspace.project.path
    stored, changed, _, _ = window.workspace.project.media_records()[-1]
    data = bytearray(changed.read_bytes())
    data[len(data) // 2 + 1] ^= 0x01
    changed.write_bytes(bytes(data))
    assert window.open_path(path, "video")
    qtbot.waitUntil(lambda: window.media_check.box is not None and not window.busy, timeout=60000)
    [button] = [b for b in window.media_check.box.buttons() if b.text() == "Accept changed media…"]
    button.click()
    qtbot.waitUntil(lambda: bool(listed) and not window.busy, timeout=60000)
    assert listed == [[stored]]
    assert window.workspace.project.media_identity(stored, full=True) is not None  # cancelled: nothing accepted
    assert window.media_check.box is None  # closed by the click: never touched again


def _flip_a_byte(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[len(data) // 2 + 1] ^= 0x01  # a repaired copy: same size, same frames, other bytes
    path.write_bytes(bytes(data))


def _opened_sample(qtbot, make_window, sample_copy):
    """A window on a copy of the video sample, its first media check done (nothing changed yet)."""
    window = make_window()
    assert window.open_path(sample_copy("rov_flatport"), "video")
    qtbot.waitUntil(lambda: window.media_check.problems is not None and not window.busy, timeout=60000)
    return window


def _reopened_with_warning(qtbot, window) -> None:
    """The project opened again, after its media changed: the check's warning box is up."""
    window.open_path(window.workspace.project.path, "video")
    qtbot.waitUntil(lambda: window.media_check.box is not None and not window.busy, timeout=60000)


def test_the_media_warning_forgets_each_file_accepted_and_closes_when_none_is_left(qtbot, make_window, sample_copy):
    window = _opened_sample(qtbot, make_window, sample_copy)
    (first, first_path, _, _), (second, second_path, _, _) = window.workspace.project.media_records()[-2:]
    _flip_a_byte(first_path)
    _flip_a_byte(second_path)
    _reopened_with_warning(qtbot, window)
    box = window.media_check.box
    assert "2 media files are not the one added" in box.text()
    media_dialogs.accept_changed_media(window.context, window, answers={first})
    qtbot.waitUntil(lambda: not window.busy, timeout=60000)
    assert window.media_check.box is box and box.isVisible()  # the other file is still changed
    assert first not in box.text() and second in box.text() and "a media file is not the one added" in box.text()
    assert [stored for stored, _ in window.media_check.problems] == [second]
    assert any(b.text() == "Accept changed media…" for b in box.buttons())
    assert box.escapeButton() is box.button(QtWidgets.QMessageBox.StandardButton.Ok)  # Escape and close() close it
    media_dialogs.accept_changed_media(window.context, window, answers={second})
    qtbot.waitUntil(lambda: not window.busy, timeout=60000)
    assert window.media_check.box is None and window.media_check.problems == []
    assert not shiboken6.isValid(box) or not box.isVisible()  # closed (and deleted)


def test_the_media_warning_forgets_a_relocated_file(qtbot, make_window, sample_copy):
    window = _opened_sample(qtbot, make_window, sample_copy)
    stored, recorded, _, _ = window.workspace.project.media_records()[-1]
    moved = recorded.parent / "elsewhere" / recorded.name
    moved.parent.mkdir()
    recorded.rename(moved)
    _reopened_with_warning(qtbot, window)  # the project opens; its missing video cannot be shown
    assert not any(b.text() == "Accept changed media…" for b in window.media_check.box.buttons())  # only missing
    assert media_dialogs.relocate_media(window.context, window, answers={stored: str(moved)}) == 1
    assert window.media_check.box is None and window.media_check.problems == []


def test_escape_closes_the_media_warning_that_offers_to_accept(qtbot, make_window, sample_copy):
    window = _opened_sample(qtbot, make_window, sample_copy)
    _flip_a_byte(window.workspace.project.media_records()[-1][1])
    _reopened_with_warning(qtbot, window)
    box = window.media_check.box
    assert len(box.buttons()) == 2
    qtbot.keyClick(box, QtCore.Qt.Key.Key_Escape)
    assert window.media_check.box is None
    assert not shiboken6.isValid(box) or not box.isVisible()
