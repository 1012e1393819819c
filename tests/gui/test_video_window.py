"""Stereo video in the window (offscreen): the sample opens on its synchronised frames, keys step on the
panes, a fish is measured on a synchronised frame within its sigma of the truth and its vertices record
the frames; a new project gets its own video and image pairs through the File menu's actions."""

import csv
import json
import os
import shutil
import sys
import threading

import numpy as np
import pytest
from PySide6 import QtCore, QtWidgets

from usvips.core.synth.frame_numbers import frame_number, numbered_frame
from usvips.gui.qt import media_dialogs
from usvips.io.images import write_image
from usvips.io.video_stream import VideoStream
from usvips.io.video_writer import encode_video


def _wait_frame(qtbot, window, frame: int) -> None:
    qtbot.waitUntil(lambda: window.workspace.video_frame is not None and window.workspace.video_frame[1] == frame
                    and not window.busy, timeout=10000)


def test_the_sample_video_shows_synchronised_frames_and_a_fish_measures_true(qtbot, make_window, sample_copy):
    directory = sample_copy("rov_flatport")
    window = make_window()
    assert window.open_path(directory, "video")
    _wait_frame(qtbot, window, 0)
    truth = json.loads((directory / "truth.json").read_text())["video"]
    with VideoStream(directory / "video_right.avi") as right:
        assert np.array_equal(window.workspace.images["right"], right.frame(3))  # offset 3 from the sample
    graphics = window.panes["left"].graphics
    qtbot.keyClick(graphics, QtCore.Qt.Key.Key_Right)
    _wait_frame(qtbot, window, 1)
    qtbot.keyClick(graphics, QtCore.Qt.Key.Key_Right, QtCore.Qt.KeyboardModifier.ShiftModifier)
    _wait_frame(qtbot, window, 11)
    qtbot.keyClick(graphics, QtCore.Qt.Key.Key_End)
    _wait_frame(qtbot, window, 26)  # the last left frame whose partner exists (29 − 3)
    qtbot.keyClick(graphics, QtCore.Qt.Key.Key_Home)
    _wait_frame(qtbot, window, 0)
    window.video.dock_widget.goto.setText("1.2s")
    window.video.dock_widget.goto.returnPressed.emit()
    _wait_frame(qtbot, window, 12)
    assert window.workspace.video_frame == ("video", 12, 15, pytest.approx(1.2))
    # measure the moving fish on this instant from the truth's pixels
    window.actions["tool_line"].trigger()
    left_truth, right_truth = truth["left"][12]["pixels"], truth["right"][15]["pixels"]
    for point in ("snout", "fork"):
        window.workspace.pick_tool.pick("left", left_truth[point])
        window.workspace.pick_tool.pick("right", right_truth[point])
    object_id = window.workspace.pick_tool.finish_object("fish2")
    stored = window.workspace.project.object(object_id)
    assert [(v.video, v.frame_left, v.frame_right) for v in stored.vertices] == [("video", 12, 15)] * 2
    assert stored.vertices[0].time_s == pytest.approx(1.2)
    figure = window.workspace.figures([object_id]).figures[0]
    fish = next(o for o in json.loads((directory / "truth.json").read_text())["objects"] if o["label"] == "fish2")
    assert abs(figure.value - fish["length"]) < figure.sigma
    assert 12 in window.video.navigator.marks and 12 in window.video.dock_widget.timeline.marks
    x = window.panes["left"].outlines_item.points()[:, 0]
    assert len(x) >= 2  # drawn on its frame ...
    window.video.request(13)
    _wait_frame(qtbot, window, 13)
    assert len(window.panes["left"].outlines_item.points()) == 0  # ... and not on the next
    # the object list shows where it was measured; double-click goes there
    table = window.object_list.table
    column = window.object_list.COLUMNS.index("frame")
    assert window.object_list.text(0, "frame") == "video: 12 | 15  00:01.200"
    table.doubleClicked.emit(table.model().index(0, column))
    _wait_frame(qtbot, window, 12)
    # stepping reads from the prefetched cache
    qtbot.waitUntil(lambda: 13 in window.video.cache and not window.busy, timeout=10000)


def test_a_new_project_gets_its_own_video_and_image_pairs(qtbot, make_window, tmp_path):
    for side, base in (("left", 0), ("right", 1000)):
        encode_video(tmp_path / f"{side}.mp4", [numbered_frame(base + i) for i in range(30)], 25, "h264", gop=15)
        (tmp_path / f"{side}_images").mkdir()
        for n in range(2):
            write_image(tmp_path / f"{side}_images" / f"st{n}_{side[0].upper()}.png", numbered_frame(base + n))
    window = make_window()
    assert media_dialogs.new_project(window.context, window, tmp_path / "mine.usvips")
    assert window.workspace.project.path.name == "mine.usvips"
    assert "is empty: add your images" in window.statusBar().currentMessage()  # not "observations only"
    shown = []
    assert media_dialogs.add_image_pairs(window.context, window, [tmp_path / "left_images"],
                                         [tmp_path / "right_images"], "a-",
                                         confirm=lambda w, model: shown.append(model) or True) == 2
    assert shown[0].rule == "shared stem" and [shown[0].label(i) for i in range(2)] == ["a-st0", "a-st1"]
    assert window.workspace.image_pairs() == ["a-st0", "a-st1"]
    qtbot.waitUntil(lambda: window.workspace.pair == "a-st0" and not window.busy, timeout=10000)
    media_dialogs.add_video(window.context, window, [tmp_path / "left.mp4"], [tmp_path / "right.mp4"], "dive")
    _wait_frame(qtbot, window, 0)
    assert "added video 'dive': left 30 frames, right 30 frames at 25 fps" in window.hint.text()
    assert frame_number(window.workspace.images["right"]) == 1000
    window.video.dock_widget.offset.setValue(2)
    window.video.dock_widget.offset.editingFinished.emit()
    qtbot.waitUntil(lambda: frame_number(window.workspace.images["right"]) == 1002 and not window.busy, timeout=10000)
    assert window.workspace.project.video("dive").offset_frames == 2
    # a moved video is relocated; a wrong file is refused
    shutil.move(tmp_path / "left.mp4", tmp_path / "moved.mp4")
    assert media_dialogs.relocate_media(window.context, window, {"left.mp4": str(tmp_path / "right.mp4")}) == 0
    assert media_dialogs.relocate_media(window.context, window, {"left.mp4": str(tmp_path / "moved.mp4")}) == 1
    assert window.workspace.project.video("dive").paths("left") == ["moved.mp4"]


def test_a_fish_measured_on_video_exports_its_frames_time_and_period(qtbot, make_window, sample_copy, tmp_path):
    directory = sample_copy("rov_flatport")
    window = make_window()
    assert window.open_path(directory, "video")
    _wait_frame(qtbot, window, 0)
    project = window.workspace.project
    assert window.video.mark_period("bait 10 26")
    assert not window.video.mark_period("late 20 40") and "not an interval" in window.statusBar().currentMessage()
    assert not window.video.mark_period("26") and project.periods("video") == [("bait", 10, 26)]
    window.video.request(20)
    _wait_frame(qtbot, window, 20)
    truth = json.loads((directory / "truth.json").read_text())["video"]
    window.actions["tool_line"].trigger()
    for point in ("snout", "fork"):
        window.workspace.pick_tool.pick("left", truth["left"][20]["pixels"][point])
        window.workspace.pick_tool.pick("right", truth["right"][23]["pixels"][point])
    object_id = window.workspace.pick_tool.finish_object("Sparidae Pagrus auratus")
    window.export_objects(tmp_path / "dive.em.txt")
    header, row = (tmp_path / "dive_Lengths.txt").read_text().splitlines()
    values = dict(zip(header.split("\t"), row.split("\t"), strict=True))
    assert (values["FilenameLeft"], values["FrameLeft"], values["FilenameRight"], values["FrameRight"]) == \
        ("video_left.avi", "20", "video_right.avi", "23")
    assert float(values["Time"]) == pytest.approx(2.0 / 60, abs=1e-4)  # minutes, as EventMeasure
    assert values["Period"] == "bait" and float(values["PeriodTime"]) == pytest.approx(1.0 / 60, abs=1e-4)
    assert values["Species"] == "auratus"
    # the objects CSV: the record's species and number, the video, its files, frames and time
    from usvips.core.observation_record import ObservationRecord

    window.workspace.edits.set_record(object_id, ObservationRecord("Sparidae", "Pagrus", "auratus", "37353001", 2))
    window.export_objects(tmp_path / "dive.csv")
    with open(tmp_path / "dive.csv", newline="") as stream:
        (row,) = list(csv.DictReader(stream))
    assert (row["species"], row["code"], row["number"]) == ("Pagrus auratus", "37353001", "2")
    assert (row["pair"], row["file_left"], row["frame_left"], row["file_right"], row["frame_right"]) == (
        "video", "video_left.avi", "20", "video_right.avi", "23")
    assert float(row["time_min"]) == pytest.approx(2.0 / 60, abs=1e-4)


def test_the_frames_shown_become_a_calibration_pair_from_the_video_dock(qtbot, make_window, sample_copy, monkeypatch):
    """The cube filmed in air: Take as pair… in the Video dock (keyboard: Alt+T, type the label, Tab, ↓ for
    'in air', Enter) writes the synchronised frames exactly and adds them as an in-air pair that the
    phase-1 calibration offers; a used label is refused before anything is written."""
    from PySide6 import QtWidgets

    from usvips.gui.calibration_session import CalibrationSession
    from usvips.gui.qt.video_controls import TakePairDialog
    from usvips.io.images import read_image

    directory = sample_copy("rov_flatport")
    window = make_window()
    assert window.open_path(directory, "video")
    _wait_frame(qtbot, window, 0)
    window.video.request(7)
    _wait_frame(qtbot, window, 7)
    project = window.workspace.project
    pairs_before = {p.label for p in project.pairs()}

    answers = []

    def fill_in(dialog: TakePairDialog) -> int:  # what a person types into the dialog, by keyboard only
        dialog.show()
        qtbot.waitExposed(dialog)
        assert dialog.label.text() == "video-7"
        dialog.label.selectAll()
        qtbot.keyClicks(dialog.label, "cube-air")
        following = dialog.label.nextInFocusChain()
        while not following.focusPolicy() & QtCore.Qt.FocusPolicy.TabFocus:
            following = following.nextInFocusChain()
        assert following is dialog.medium  # Tab goes from the label to the medium
        dialog.medium.setFocus()
        qtbot.keyClick(dialog.medium, QtCore.Qt.Key.Key_Down)
        answers.append((dialog.label.text(), dialog.medium.currentData()))
        return QtWidgets.QDialog.DialogCode.Accepted

    monkeypatch.setattr(TakePairDialog, "exec", fill_in)
    window.video.dock_widget.take.click()
    assert answers == [("cube-air", "air")]
    qtbot.waitUntil(lambda: "cube-air" in {p.label for p in project.pairs()} and not window.busy, timeout=10000)
    pair = next(p for p in project.pairs() if p.label == "cube-air")
    assert pair.medium == "air" and (pair.width, pair.height) == (VideoStream(directory / "video_left.avi")
                                                                           .size)
    with VideoStream(directory / "video_left.avi") as left, VideoStream(directory / "video_right.avi") as right:
        assert np.array_equal(read_image(project.image_path(pair.left)), left.frame(7))
        assert np.array_equal(read_image(project.image_path(pair.right)), right.frame(10))  # offset 3
    assert "cube-air" in [window.pair_box.itemText(i) for i in range(window.pair_box.count())]
    assert window.workspace.video_frame[1] == 7  # still on the video
    assert "cube-air" in CalibrationSession(project, "air").candidate_pairs()
    # a label already used is refused before anything is written
    written = (directory / "frames" / "cube-air" / "left.png").stat().st_mtime_ns
    window.video.request(9)
    _wait_frame(qtbot, window, 9)
    assert window.video.take_pair("cube-air", "air") is None
    assert "already used" in window.statusBar().currentMessage()
    assert (directory / "frames" / "cube-air" / "left.png").stat().st_mtime_ns == written
    assert {p.label for p in project.pairs()} == pairs_before | {"cube-air"}


def test_seek_proxies_are_offered_at_the_first_slow_seek_built_in_the_background_used_cancelled_and_deleted(
        qtbot, make_window, tmp_path):
    for side, base in (("left", 0), ("right", 1000)):
        encode_video(tmp_path / f"{side}.mp4", [numbered_frame(base + i) for i in range(40)], 25, "h264", gop=40)
    window = make_window()
    assert media_dialogs.new_project(window.context, window, tmp_path / "mine.usvips")
    media_dialogs.add_video(window.context, window, [tmp_path / "left.mp4"], [tmp_path / "right.mp4"], "dive")
    video, dock = window.video, window.video.dock_widget
    _wait_frame(qtbot, window, 0)  # shown from the originals, and nothing asked on opening
    assert video.question is None and video._proxy_worker is None
    # the first slow seek asks (every seek counts as slow here), saying their size on disk; Yes builds them
    # in the background, checked, then used
    video.slow_seek_s = 0.0
    video.cache.clear()
    video.request(17)
    _wait_frame(qtbot, window, 17)
    qtbot.waitUntil(lambda: video.question is not None and video.question.isVisible(), timeout=20000)
    question = video.question
    assert "Build seek proxies for video dive?" in question.text() and " on disk " in question.text()
    assert question.defaultButton() is question.button(QtWidgets.QMessageBox.StandardButton.No)
    question.button(QtWidgets.QMessageBox.StandardButton.Yes).click()
    qtbot.waitUntil(lambda: video.source is not None and video.source.has_proxies, timeout=20000)
    assert "seek proxies built and checked" in window.statusBar().currentMessage()
    assert dock.proxy_status.text() == "proxy ✓" and dock.proxy.text() == "Seek pro&xy"
    folder = tmp_path / "proxies"
    assert len(list(folder.glob("*.proxy.nut"))) == 2
    for frame in (31, 3, 22):  # random seeks through the proxies, forwards and backwards
        video.request(frame)
        _wait_frame(qtbot, window, frame)
        assert frame_number(window.workspace.images["left"]) == frame
        assert frame_number(window.workspace.images["right"]) == 1000 + frame
    assert video.build_proxies() is None and "already built" in window.statusBar().currentMessage()
    # Delete seek proxy: gone from the disk, seeks decode the originals, not rebuilt by itself
    dock.delete_proxy_action.trigger()
    assert not any(folder.iterdir()) and not video.source.left.has_proxy and not video.source.right.has_proxy
    assert "seek proxies deleted" in window.statusBar().currentMessage() and dock.proxy_status.text() == ""
    video.request(29)
    _wait_frame(qtbot, window, 29)
    assert frame_number(window.workspace.images["right"]) == 1029
    assert video.open_video("dive") and video._proxy_worker is None
    # built by hand and cancelled at once: nothing half-written stays, the originals keep being used
    assert video.build_proxies() is not None and dock.proxy.text() == "Cancel pro&xy"
    dock.proxy.click()  # the button cancels while building
    qtbot.waitUntil(lambda: video._proxy_worker is None, timeout=20000)
    assert "cancelled" in window.statusBar().currentMessage()
    assert not any(folder.iterdir()) and not video.source.has_proxies
    dock.proxy.click()  # and builds again
    qtbot.waitUntil(lambda: video.source is not None and video.source.has_proxies, timeout=20000)
    video.request(35)
    _wait_frame(qtbot, window, 35)
    assert frame_number(window.workspace.images["left"]) == 35


def test_the_video_dock_fits_1366_px_and_is_driven_by_the_keyboard(qtbot, make_window, tmp_path):
    for side, base in (("left", 0), ("right", 1000)):
        encode_video(tmp_path / f"{side}.mp4", [numbered_frame(base + i) for i in range(60)], 25, "h264", gop=60)
    window = make_window()  # 1366 × 768
    window.video.auto_proxies = False
    assert media_dialogs.new_project(window.context, window, tmp_path / "mine.usvips")
    media_dialogs.add_video(window.context, window, [tmp_path / "left.mp4"], [tmp_path / "right.mp4"], "dive")
    _wait_frame(qtbot, window, 0)
    dock = window.video.dock_widget
    qtbot.waitUntil(lambda: dock.isVisible() and dock.width() > 0, timeout=5000)
    assert window.width() <= 1366
    # nothing cut: every control lies inside the dock and gets at least the width it asks for
    controls = (dock.chooser, dock.play, dock.rate, dock.jump, dock.offset, dock.sync, dock.period, dock.take,
                dock.proxy, dock.goto, dock.timeline, dock.frame_label)
    qtbot.waitUntil(lambda: all(w.width() >= w.minimumSizeHint().width() for w in controls), timeout=5000)
    for widget in controls:
        assert widget.isVisible()
        rect = QtCore.QRect(widget.mapTo(dock, QtCore.QPoint(0, 0)), widget.size())
        assert dock.rect().contains(rect), widget
    metrics = dock.goto.fontMetrics()
    assert dock.goto.width() >= metrics.horizontalAdvance(dock.goto.placeholderText()) + 8
    assert dock.frame_label.width() >= dock.frame_label.fontMetrics().horizontalAdvance(dock.frame_label.text())
    # the tab order runs through every control of the dock
    seen, widget = [], dock.chooser
    for _ in range(len(controls)):
        seen.append(widget)
        widget = widget.nextInFocusChain()
        while widget.focusPolicy() == QtCore.Qt.FocusPolicy.NoFocus or widget.parent() is None:
            widget = widget.nextInFocusChain()
    for widget in controls[:-1]:
        assert widget in seen or widget is dock.timeline, widget
    # Ctrl+G goes to the go-to field; a time code and Enter show that frame
    window.panes["left"].graphics.setFocus()
    qtbot.keyClick(window, QtCore.Qt.Key.Key_G, QtCore.Qt.KeyboardModifier.ControlModifier)
    assert dock.goto.hasFocus()
    qtbot.keyClicks(dock.goto, "1.2s")
    qtbot.keyClick(dock.goto, QtCore.Qt.Key.Key_Return)
    _wait_frame(qtbot, window, 30)
    # arrows, Shift+arrows, Home/End on the panes
    pane = window.panes["left"].graphics
    for key, modifier, frame in ((QtCore.Qt.Key.Key_Right, QtCore.Qt.KeyboardModifier.NoModifier, 31),
                                 (QtCore.Qt.Key.Key_Left, QtCore.Qt.KeyboardModifier.ShiftModifier, 21),
                                 (QtCore.Qt.Key.Key_End, QtCore.Qt.KeyboardModifier.NoModifier, 59),
                                 (QtCore.Qt.Key.Key_Home, QtCore.Qt.KeyboardModifier.NoModifier, 0)):
        qtbot.keyClick(pane, key, modifier)
        _wait_frame(qtbot, window, frame)
    # every button has its Alt mnemonic, every field a label with one
    for button in (dock.play, dock.sync, dock.period, dock.take, dock.proxy):
        assert "&" in button.text(), button.text()
    buddies = {label.buddy() for label in dock.findChildren(QtWidgets.QLabel) if "&" in label.text()}
    assert {dock.chooser, dock.jump, dock.offset, dock.goto} <= buddies
    for letter, field in (("D", dock.chooser), ("J", dock.jump), ("S", dock.offset), ("G", dock.goto)):
        pane.setFocus()
        qtbot.keyClick(pane, getattr(QtCore.Qt.Key, f"Key_{letter}"), QtCore.Qt.KeyboardModifier.AltModifier)
        assert field.hasFocus(), letter


@pytest.mark.parametrize("lag", [4, -3])
def test_the_offset_is_estimated_in_the_window_and_stored(qtbot, make_window, tmp_path, lag):
    """A light switched on, seen by both cameras: Sync… estimates the offset in a worker, stores it, says
    so with its confidence, and both panes then show the same instant."""
    for side, shift, base in (("left", 0, 0), ("right", lag, 1000)):
        frames = [numbered_frame(base + j - shift if j - shift >= 0 else 3000 + j, seed=1,
                                 brightness=60.0 if j - shift >= 30 else 0.0) for j in range(70)]
        encode_video(tmp_path / f"{side}.mp4", frames, 25, "h264", gop=25)
    window = make_window()
    window.video.ask_before_proxies = False  # built without the question here (see the proxies' own test)
    assert media_dialogs.new_project(window.context, window, tmp_path / "mine.usvips")
    media_dialogs.add_video(window.context, window, [tmp_path / "left.mp4"], [tmp_path / "right.mp4"], "dive")
    _wait_frame(qtbot, window, 0)
    # the seek proxies built by themselves first (their message would otherwise replace the estimate's)
    qtbot.waitUntil(lambda: window.video.source is not None and window.video.source.has_proxies, timeout=20000)
    assert window.video.synchronise("flash") is not None
    qtbot.waitUntil(lambda: window.workspace.project.video("dive").offset_frames == lag and not window.busy,
                    timeout=60000)
    assert "by flash, confidence" in window.statusBar().currentMessage()
    assert window.video.dock_widget.offset.value() == lag
    frame = 40
    window.video.request(frame)
    _wait_frame(qtbot, window, frame)
    assert frame_number(window.workspace.images["right"]) == 1000 + frame  # the same instant


@pytest.mark.parametrize("answer", ["Return", "Yes"])
def test_an_estimate_of_little_confidence_is_stored_only_if_the_user_says_so(qtbot, make_window, sample_copy, answer):
    """The sample has no flash: Sync by flash finds an offset with little confidence, says it is not stored
    and asks, without blocking the window, whether to store it anyway (Return: No, the default)."""
    window = make_window()
    assert window.open_path(sample_copy("rov_flatport"), "video")
    _wait_frame(qtbot, window, 0)
    assert window.video.synchronise("flash") is not None
    qtbot.waitUntil(lambda: window.video.question is not None and window.video.question.isVisible(), timeout=60000)
    question = window.video.question
    assert "Store" in question.text() and "confidence" in question.text()
    assert "not stored" in window.statusBar().currentMessage()
    if answer == "Return":
        qtbot.keyClick(question, QtCore.Qt.Key.Key_Return)
    else:
        question.button(QtWidgets.QMessageBox.StandardButton.Yes).click()
    qtbot.waitUntil(lambda: not question.isVisible(), timeout=5000)
    stored = window.workspace.project.video("video")
    if answer == "Yes":
        assert stored.offset_estimate["method"] == "flash" and window.video.dock_widget.offset.value() != 3
    else:
        assert stored.offset_frames == 3 and stored.offset_estimate.get("method") != "flash"


def test_an_estimate_at_the_edge_of_its_window_is_not_offered_for_storing(qtbot, make_window, sample_copy,
                                                                         monkeypatch):
    """An offset at the edge of its search window (and of little confidence, which alone would ask) is no
    estimate: the window says why, asks nothing and stores nothing."""
    from usvips.app import video_project
    from usvips.core.synchronisation import SyncEstimate

    estimate = SyncEstimate(-7.8, 25.0, "flash", 0.3, window=(-8, 8))
    monkeypatch.setattr(video_project, "run_sync", lambda job, method, progress=None: estimate)
    window = make_window()
    assert window.open_path(sample_copy("rov_flatport"), "video")
    _wait_frame(qtbot, window, 0)
    before = window.workspace.project.video("video")
    assert window.video.synchronise("flash") is not None
    qtbot.waitUntil(lambda: "not stored" in window.statusBar().currentMessage() and not window.busy, timeout=60000)
    message = window.statusBar().currentMessage()
    assert "edge of the search window" in message and "-8 to +8" in message
    assert window.video.question is None or not window.video.question.isVisible()
    assert window.workspace.project.video("video").offset_frames == before.offset_frames
    assert window.workspace.project.video("video").offset_estimate == before.offset_estimate
    assert window.video.dock_widget.offset.value() == before.offset_frames


def test_quick_steps_add_up_while_a_frame_is_still_decoding(qtbot, make_window, sample_copy):
    window = make_window()
    assert window.open_path(sample_copy("rov_flatport"), "video")
    _wait_frame(qtbot, window, 0)
    window.video.cache.clear()  # nothing prefetched: both steps must decode
    graphics = window.panes["left"].graphics
    qtbot.keyClick(graphics, QtCore.Qt.Key.Key_Right, QtCore.Qt.KeyboardModifier.ShiftModifier)
    qtbot.keyClick(graphics, QtCore.Qt.Key.Key_Right, QtCore.Qt.KeyboardModifier.ShiftModifier)
    _wait_frame(qtbot, window, 20)
    qtbot.keyClick(graphics, QtCore.Qt.Key.Key_Left)
    _wait_frame(qtbot, window, 19)


def test_a_proxy_folder_that_cannot_be_written_leaves_the_original_in_use_with_one_line(qtbot, make_window, tmp_path):
    for side, base in (("left", 0), ("right", 1000)):
        encode_video(tmp_path / f"{side}.mp4", [numbered_frame(base + i) for i in range(40)], 25, "h264", gop=40)
    (tmp_path / "proxies").write_text("a file where the proxies' folder would be")
    window = make_window()
    said = []
    window.messages.said.connect(lambda kind, text: said.append((kind, text)))  # the controllers' messages
    window.video.ask_before_proxies = False  # built without the question here (see the proxies' own test)
    assert media_dialogs.new_project(window.context, window, tmp_path / "mine.usvips")
    media_dialogs.add_video(window.context, window, [tmp_path / "left.mp4"], [tmp_path / "right.mp4"], "dive")
    _wait_frame(qtbot, window, 0)
    qtbot.waitUntil(lambda: any("not built" in text for _, text in said), timeout=20000)
    kind, message = next((k, text) for k, text in said if "not built" in text)
    assert kind == "warning"
    assert "cannot write a seek proxy here" in message and "\n" not in message and str(tmp_path / "proxies") in message
    assert window.video._proxy_worker is None and not window.video.source.has_proxies
    window.video.request(33)
    _wait_frame(qtbot, window, 33)
    assert frame_number(window.workspace.images["left"]) == 33


def test_the_video_box_names_no_video_until_one_is_shown_and_its_controls_open_the_only_one(
        qtbot, make_window, sample_copy):
    """A project with image pairs and a video opens on a pair: the Video box says "choose…" (not the
    video's name, as if it were shown); Play, Go to (Ctrl+G) and Sync open the project's only video rather
    than doing nothing; showing an image pair leaves the video (the arrows no longer step it)."""
    from usvips.gui.qt.video_controls import NONE_SHOWN

    directory = sample_copy("rov_flatport")
    window = make_window()
    assert window.open_path(directory, "measure1")
    qtbot.waitUntil(lambda: window.workspace.pair == "measure1" and not window.busy, timeout=10000)
    d = window.video.dock_widget
    assert d.chooser.currentIndex() == -1 and d.chooser.placeholderText() == NONE_SHOWN and d.chooser.count() == 1
    assert window.video.navigator is None and d.frame_label.text() == "—"
    qtbot.mouseClick(d.play, QtCore.Qt.MouseButton.LeftButton)  # Play: the only video opens and plays
    assert window.video.navigator is not None and d.chooser.currentText() == "video" and d.play.isChecked()
    qtbot.waitUntil(lambda: window.workspace.video_frame is not None and window.workspace.video_frame[1] > 0,
                    timeout=20000)
    qtbot.mouseClick(d.play, QtCore.Qt.MouseButton.LeftButton)  # pause
    qtbot.waitUntil(lambda: not window.busy, timeout=10000)
    # an image pair shown: the video is left, the box says so, the arrows on the panes step nothing
    window.load_pair("water1")
    qtbot.waitUntil(lambda: window.workspace.pair == "water1" and not window.busy, timeout=10000)
    assert window.video.navigator is None and d.chooser.currentIndex() == -1 and d.frame_label.text() == "—"
    assert not d.play.isChecked() and d.play.text() == "&Play"
    assert (d.offset.value(), d.timeline.maximum(), d.goto.text()) == (0, 0, "")  # nothing of the video left
    qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_Right)
    QtWidgets.QApplication.processEvents()
    assert window.workspace.pair == "water1" and window.workspace.video_frame is None
    # Ctrl+G from the panes: the video opens and the go-to field takes the frame typed
    window.focus_images()
    qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_G, QtCore.Qt.KeyboardModifier.ControlModifier)
    assert window.video.navigator is not None
    qtbot.waitUntil(d.goto.hasFocus, timeout=5000)
    qtbot.keyClicks(d.goto, "7")
    qtbot.keyClick(d.goto, QtCore.Qt.Key.Key_Return)
    _wait_frame(qtbot, window, 7)
    # with the video left and nothing to choose from, a control says why instead of doing nothing
    window.load_pair("water1")
    qtbot.waitUntil(lambda: window.workspace.pair == "water1" and not window.busy, timeout=10000)
    d.chooser.clear()
    qtbot.mouseClick(d.sync, QtCore.Qt.MouseButton.LeftButton)
    assert window.video.navigator is None and "no stereo video" in window.hint.text()


def test_a_video_chosen_while_the_first_pair_is_still_read_stays_shown(qtbot, make_window, sample_copy):
    directory = sample_copy("rov_flatport")
    window = make_window()
    assert window.open_path(directory)  # its first image pair is read in a worker ...
    assert window.video.open_video("video")  # ... and the video is asked for meanwhile
    qtbot.waitUntil(lambda: not window.busy and window.workspace.video_frame is not None, timeout=20000)
    for _ in range(5):
        QtWidgets.QApplication.processEvents()
    assert window.workspace.video_frame[0] == "video" and window.video.navigator is not None


def test_the_pane_titles_keep_the_video_frame_when_the_pair_is_shown_again(qtbot, make_window, sample_copy):
    """Making a calibration active shows the pair again (Workspace.reshow_pair): the titles came from the
    video controller only when it showed a frame, so they turned into "Left — video (640 × 480 px)"."""
    window = make_window()
    assert window.open_path(sample_copy("rov_flatport"), "video")
    _wait_frame(qtbot, window, 0)
    window.video.request(4)
    _wait_frame(qtbot, window, 4)
    titles = [window.panes[side].title.text() for side in ("left", "right")]
    assert titles == ["Left — video, frame 4  00:00.400", "Right — video, frame 7  00:00.400"]
    window.workspace.reshow_pair()  # what making a calibration active does
    assert [window.panes[side].title.text() for side in ("left", "right")] == titles
    window.load_pair("measure1")
    qtbot.waitUntil(lambda: window.workspace.pair == "measure1" and not window.busy, timeout=10000)
    assert window.panes["left"].title.text() == "Left — measure1  (640 × 480 px)"


def test_seek_proxies_declined_are_not_offered_again_after_another_project(qtbot, make_window, tmp_path):
    """No is kept for the session: coming back from another project asked again (and the question took
    the frame typed after Ctrl+G)."""
    from shiboken6 import isValid

    from usvips.store import Project

    def asked() -> bool:
        return video.question is not None and isValid(video.question) and video.question.isVisible()

    for side, base in (("left", 0), ("right", 1000)):
        encode_video(tmp_path / f"{side}.mp4", [numbered_frame(base + i) for i in range(12)], 25, "h264", gop=12)
    window = make_window()
    assert media_dialogs.new_project(window.context, window, tmp_path / "mine.usvips")
    media_dialogs.add_video(window.context, window, [tmp_path / "left.mp4"], [tmp_path / "right.mp4"], "dive")
    video = window.video
    video.slow_seek_s = 0.0  # every seek counts as slow here
    _wait_frame(qtbot, window, 0)
    video.cache.clear()
    video.request(7)
    qtbot.waitUntil(asked, timeout=20000)
    video.question.button(QtWidgets.QMessageBox.StandardButton.No).click()
    qtbot.waitUntil(lambda: not asked(), timeout=5000)
    other = tmp_path / "other.usvips"
    Project.create(other).close()
    assert window.open_path(other)
    assert window.open_path(tmp_path / "mine.usvips") and video.navigator is not None
    _wait_frame(qtbot, window, 0)
    video.cache.clear()
    video.request(9)
    _wait_frame(qtbot, window, 9)
    for _ in range(5):
        QtWidgets.QApplication.processEvents()
    assert not asked() and video._proxy_worker is None


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="a thread's own priority is Linux's")
def test_a_frame_stepped_to_is_decoded_at_the_guis_priority_after_bulk_work(qtbot, make_window, sample_copy):
    """Bulk work (figures, tracking, detection) runs nicer than the GUI thread and its pool threads stay so;
    the frame a user steps to is decoded in the video controls' own pool, at the GUI thread's priority."""
    from usvips.gui.qt.worker import Worker, start

    window = make_window()
    assert window.open_path(sample_copy("rov_flatport"), "video")
    _wait_frame(qtbot, window, 0)
    for _ in range(4):  # bulk work in the window's pools first
        bulk = Worker(lambda progress, cancelled: None, "bulk work")
        with qtbot.waitSignal(bulk.signals.finished, timeout=10000):
            start(bulk, window.pool)
    gui = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
    seen = []
    source = window.video.source
    decode = source.pictures

    def pictures(*args, **kwargs):
        seen.append(os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))
        return decode(*args, **kwargs)

    source.pictures = pictures
    window.video.cache.clear()
    qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_Right)
    _wait_frame(qtbot, window, 1)
    assert seen and all(priority == gui for priority in seen)
