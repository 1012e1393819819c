"""Tracking and instants in the window (offscreen), on a project holding a rendered stereo video of a
swimming fish with known truth: T tracks the selected length's vertices in a worker (drawn on both panes
and on the timeline), Cancel stops it within a frame, Ctrl+T stores instants whose combined figure the
object list shows (undoable), the instants dialog lists them and goes to their frames, P proposes the
vertices on a later frame, and bad input is refused in one line with nothing stored."""

import shutil
import threading
import time

import numpy as np
import pytest
from PySide6 import QtCore

from tests.core.test_tracking import truth
from tests.gui.swimming_project import BLANK, FRAMES, OFFSET, POINTS, START, make_survey_project
from usvips.app.project_figures import evaluate, measurement_input
from usvips.app.tracking import VideoTracker
from usvips.gui.qt.pane import item_from_pixels
from usvips.store import Project
from usvips.store.project import Vertex


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tracking_window")
    return make_survey_project(folder)


@pytest.fixture
def survey(built, request):
    path, object_id, fish, stereo = built
    copy = path.with_name(f"{request.node.name[:40]}.usvips")
    shutil.copy(path, copy)
    return copy, object_id, fish, stereo


def _open(qtbot, make_window, path, object_id, frame=START):
    window = make_window()
    window.video.auto_proxies = False
    assert window.open_path(path, "drop")
    window.video.request(frame)
    _wait_frame(qtbot, window, frame)
    window.workspace.select([object_id])
    window.focus_images()
    return window


def _wait_frame(qtbot, window, frame):
    qtbot.waitUntil(lambda: window.workspace.video_frame is not None and window.workspace.video_frame[1] == frame
                    and not window.busy, timeout=15000)


def _status(window):
    return window.statusBar().currentMessage()


def test_t_tracks_the_object_draws_it_and_ctrl_t_stores_instants_with_the_combined_figure(qtbot, make_window, survey):
    path, object_id, fish, stereo = survey
    window = _open(qtbot, make_window, path, object_id)
    qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_T)
    assert window.busy  # the work runs in a worker
    qtbot.waitUntil(lambda: window.tracking.model.complete and not window.busy, timeout=30000)
    model = window.tracking.model
    last = FRAMES - 1 - OFFSET  # the right video's last partner
    assert model.span() == (0, last) and model.object_id == object_id
    for vertex, point in enumerate(POINTS):
        track = model.tracks[vertex]
        assert "no right partner" in track.reason(+1)
        for frame, left, right in zip(track.frames, track.left, track.right, strict=True):
            true_left, true_right = truth(stereo, fish, frame, point * fish.length)
            assert np.linalg.norm(left - true_left) < 0.5 and np.linalg.norm(right - true_right) < 0.5
    timeline = window.video.dock_widget.timeline
    assert timeline.track_span == (0, last) and timeline.track_stops == {last}
    assert "tracked object" in _status(window)
    # drawn on both panes at the frame shown: the tracked points and a trail of the frames before
    window.video.request(10)
    _wait_frame(qtbot, window, 10)
    for side, column in (("left", 0), ("right", 1)):
        trail, points = window.tracking.items[side]
        drawn = points.points()
        expected = item_from_pixels(np.array([truth(stereo, fish, 10, f * fish.length)[column] for f in POINTS]))
        assert drawn.shape == (2, 2) and np.abs(drawn - expected).max() < 0.5
        x = trail.points()[:, 0]
        assert np.isfinite(x).sum() == 2 * 11  # frames 0 to 10 of each vertex's trail
    # Ctrl+T: instants every 4 frames from the object's frame (2, 10, 14, 18; 22 has no right partner)
    ids = window.tracking.store_instants("4")
    project = window.workspace.project
    assert project.instants(object_id) == ids and len(ids) == 4
    assert [project.object(i).vertices[0].frame_left for i in ids] == [2, 10, 14, 18]
    assert "over 5 instants" in _status(window)
    # on the frame shown (10) the instant measured there is labelled as its object's
    qtbot.waitUntil(lambda: any(label.toPlainText().startswith(f"{ids[1]}: instant of {object_id} ")
                                for label in window.panes["left"].labels), timeout=10000)
    combined = evaluate(measurement_input(project, project.object(object_id)))
    qtbot.waitUntil(lambda: window.workspace.cache.known_figures(object_id) is not None, timeout=10000)
    assert window.workspace.cache.known_figures(object_id).figures[0].value == combined.figures[0].value
    row = window.object_list.row_of(object_id)
    column = window.object_list.COLUMNS.index("figure")
    qtbot.waitUntil(lambda: window.object_list.text(row, "figure") != "computing…", timeout=10000)
    shown = window.object_list.text(row, "figure")
    assert f"{combined.figures[0].sigma * 1000:.1f} mm" in shown and combined.combined[0].count == 5
    assert shown.endswith("(5 instants)")  # the object's row: the combined figure over its 5 instants
    assert window.object_list.text(window.object_list.row_of(ids[0]), "figure") == f"instant of #{object_id}"
    distances = [np.linalg.norm(fish.body_point(f / 25.0, POINTS[1] * fish.length)
                                - fish.body_point(f / 25.0, POINTS[0] * fish.length)) for f in (START, 2, 10, 14, 18)]
    assert abs(combined.figures[0].value - np.mean(distances)) < 3 * combined.figures[0].sigma
    # undoable: Ctrl+Z takes the instants away, Ctrl+Shift+Z puts the same ones back
    window.undo()
    assert project.instants(object_id) == [] and not set(ids) & set(window.workspace.cache.ids())
    window.redo()
    assert project.instants(object_id) == ids and set(ids) <= set(window.workspace.cache.ids())
    # the instants dialog: each instant with its weight, the combined figure; Enter goes to an instant's frame
    # from the object list: its context menu (or Ctrl+I there) opens the selected object's instants
    window.workspace.select([object_id])
    listed = window.actions["instants_of_listed"]
    assert listed in window.object_list.table.actions()
    listed.trigger()
    view = window.instants_view
    assert view.isVisible() and view.table.rowCount() == 5
    assert "over 5 instants" in view.summary.text() and "p = " in view.summary.text()
    weights = [float(view.table.item(r, 3).text().rstrip("%")) for r in range(5)]
    assert abs(sum(weights) - 100) <= 3
    view.table.setCurrentCell(3, 0)
    qtbot.keyClick(view.table, QtCore.Qt.Key.Key_Return)
    _wait_frame(qtbot, window, 10)
    # remove an instant from the object: it stays an object of its own; undoable
    view.table.setCurrentCell(1, 0)
    assert view.remove_current()
    assert project.instants(object_id) == ids[1:] and view.table.rowCount() == 4 and ids[0] in window.workspace.cache
    window.undo()
    assert project.instants(object_id) == ids and view.table.rowCount() == 5


def test_the_tracking_keys_are_in_the_measure_menu_and_the_guide(qtbot, make_window):
    from usvips.gui.qt.main_window import quick_guide

    window = make_window()
    measure = next(a.menu() for a in window.menuBar().actions() if a.text() == "&Measure")
    keys = {a.text(): a.shortcut().toString() for a in measure.actions()}
    assert keys["&Track the object's vertices"] == "T" and keys["&Re-follow from here"] == "Shift+T"
    assert keys["Store trac&ks as instants…"] == "Ctrl+T" and keys["Propose from the &earlier instant"] == "P"
    assert keys["&Instants of the object…"] == "I"
    for text in ("<b>T</b>", "<b>Shift+T</b>", "<b>Ctrl+T</b>", "<b>P</b>", "<b>I</b>"):
        assert text in quick_guide()


def test_cancel_stops_tracking_within_a_frame_and_nothing_changes(qtbot, make_window, survey, monkeypatch):
    path, object_id, fish, stereo = survey
    window = _open(qtbot, make_window, path, object_id)
    original = VideoTracker.track_many
    started, after_cancel = threading.Event(), []

    def held(self, start, picks, first, last, settings, cancel, progress):
        def watched(done, total):
            if started.is_set():
                after_cancel.append(done)  # a frame tracked after the cancel was asked for
            started.set()
            for _ in range(1000):  # hold the first frame until the window cancels (at most 10 s)
                if cancel():
                    break
                time.sleep(0.01)
            progress(done, total)

        return original(self, start, picks, first, last, settings, cancel, watched)

    monkeypatch.setattr(VideoTracker, "track_many", held)
    worker = window.tracking.track()
    assert worker is not None and started.wait(20)
    window.cancel_button.click()
    qtbot.waitUntil(lambda: not window.busy, timeout=15000)
    assert after_cancel == [] and worker.is_cancelled
    assert window.tracking.model.object_id is None and "cancelled" in _status(window)


def test_bad_input_is_refused_in_one_line_and_nothing_is_stored(qtbot, make_window, survey):
    path, object_id, fish, stereo = survey
    with Project.open(path) as project:
        stored = project.object(object_id)
        calibration_id = stored.vertices[0].calibration_id
        x0, y0, x1, y1 = BLANK
        middle = ((x0 + x1) / 2, (y0 + y1) / 2)
        blank = project.add_object("point", [Vertex(*middle, *middle, (0.0, 0.0, -1.0), np.eye(3) * 1e-6,
                                                    calibration_id, "drop", "drop", START, START + OFFSET,
                                                    START / 25.0)])
        other = project.add_calibration("other", project.calibration(calibration_id), ())
        elsewhere = project.add_object("length", [Vertex(v.xl, v.yl, v.xr, v.yr, v.xyz, v.covariance, other, "drop",
                                                         "drop", 10, 10 + OFFSET, 10 / 25.0) for v in stored.vertices])
    window = _open(qtbot, make_window, path, blank)
    # a track started on a featureless patch
    window.tracking.track()
    qtbot.waitUntil(lambda: not window.busy, timeout=15000)
    assert "featureless patch" in _status(window) and window.tracking.model.object_id is None
    # instants on a frame the tracks do not reach (no right partner there): refused by name, nothing stored
    window.workspace.select([object_id])
    window.tracking.track()
    qtbot.waitUntil(lambda: window.tracking.model.complete and not window.busy, timeout=30000)
    project = window.workspace.project
    assert window.tracking.store_instants("4, 22") == []
    assert "frame 22: the track of vertex 1 does not reach it" in _status(window) and "no right partner" in \
        _status(window)
    assert project.instants(object_id) == []
    assert window.tracking.store_instants("x") == [] and "'x' is not a whole number" in _status(window)
    # an instant on another calibration
    assert not window.tracking.join(object_id, elsewhere)
    assert "calibration" in _status(window) and project.instants(object_id) == []
    # tracked instants measured with a calibration made active for the video since: refused, nothing stored
    count = len(project.objects())
    project.add_calibration("newer", project.calibration(other), ("drop",))
    assert window.tracking.store_instants("4") == []
    assert "no instants stored" in _status(window) and "calibration" in _status(window)
    assert project.instants(object_id) == [] and len(project.objects()) == count
    # no video shown
    window.workspace.video_frame = None
    assert window.tracking.track() is None and "stereo video" in _status(window)


def test_p_proposes_the_vertices_on_a_later_frame_and_the_new_object_joins_as_an_instant(qtbot, make_window, survey):
    path, object_id, fish, stereo = survey
    window = _open(qtbot, make_window, path, object_id, frame=12)
    ws = window.workspace
    qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_P)
    qtbot.waitUntil(lambda: ws.pick_tool.state.proposal is not None and not window.busy, timeout=30000)
    for k, point in enumerate(POINTS):
        true_left, true_right = truth(stereo, fish, 12, point * fish.length)
        assert np.linalg.norm(np.subtract(ws.pick_tool.state.left, true_left)) < 0.5
        assert np.linalg.norm(np.subtract(ws.pick_tool.state.proposal, true_right)) < 0.5
        assert f"vertex {k + 1} of 2" in ws.pick_tool.state.note
        qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_Return)  # Enter accepts
    assert len(ws.pick_tool.digitising.vertices) == 2 and ws.pick_tool.state.proposal is None
    qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_Return)  # Enter stores the new object
    project = ws.project
    qtbot.waitUntil(lambda: len(project.instants(object_id)) == 1, timeout=5000)
    new = project.instants(object_id)[0]
    assert project.object(new).vertices[0].frame_left == 12 and "instant of object" in _status(window)
    # its vertices were kept as proposed: they carry the start pick's error, so it is a tracked instant
    assert project.instant_sources(object_id) == {new: START}
    # the observation form did not ask for the instant's species (its object's record holds it)
    assert window.observation.ask.isChecked() and window.observation.status.text() == ""
    assert not window.observation.species.hasFocus()
    # with nothing selected, T tracks the object just stored (from its own frame, 12)
    ws.select([])
    window.tracking.track()
    qtbot.waitUntil(lambda: window.tracking.model.complete and not window.busy, timeout=30000)
    assert window.tracking.model.object_id == new and window.tracking.model.start == 12


def test_p_with_the_images_zoomed_elsewhere_brings_each_proposed_point_into_view(qtbot, make_window, survey):
    """Zoomed far from the fish, P pans both panes to each proposed point (keeping the zoom), so that a
    proposal is never accepted unseen."""
    path, object_id, fish, stereo = survey
    window = _open(qtbot, make_window, path, object_id, frame=12)
    ws = window.workspace
    for side in ("left", "right"):
        window.panes[side].zoom_to(8.0, (3.0, 3.0))  # the top-left corner, far from the fish
    qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_P)
    qtbot.waitUntil(lambda: ws.pick_tool.state.proposal is not None and not window.busy, timeout=30000)
    for _ in range(2):
        state = ws.pick_tool.state
        assert window.panes["left"].in_view(state.left) and window.panes["right"].in_view(state.proposal)
        assert abs(window.panes["left"].zoom_level() - 8.0) < 0.5  # the zoom kept
        qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_Return)


def test_shift_t_re_follows_a_vertex_from_the_point_re_picked_on_the_frame_shown(qtbot, make_window, survey):
    path, object_id, fish, stereo = survey
    window = _open(qtbot, make_window, path, object_id)
    ws = window.workspace
    window.tracking.track()
    qtbot.waitUntil(lambda: window.tracking.model.complete and not window.busy, timeout=30000)
    qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_T, QtCore.Qt.KeyboardModifier.ShiftModifier)
    assert "re-pick the point on this frame" in _status(window)  # nothing re-picked yet
    window.video.request(12)
    _wait_frame(qtbot, window, 12)
    # the user re-picks the second vertex on frame 12 (pick tool: left, then its partner)
    true_left, true_right = truth(stereo, fish, 12, POINTS[1] * fish.length)
    ws.pick_tool.pick("left", tuple(true_left + (0.2, -0.1)))
    ws.pick_tool.pick("right", tuple(true_right))
    assert ws.pick_tool.last_point is not None
    before = window.tracking.model.tracks[1]
    qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_T, QtCore.Qt.KeyboardModifier.ShiftModifier)
    qtbot.waitUntil(lambda: window.tracking.model.corrected.get(1) == {12} and not window.busy, timeout=30000)
    after = window.tracking.model.tracks[1]
    assert np.array_equal(after.frames, before.frames) and np.array_equal(after.left[:12], before.left[:12])
    assert np.allclose(after.left[12], true_left + (0.2, -0.1), atol=1e-6)  # the re-picked point, followed on
    assert "re-followed from frame 12" in _status(window)
    _, points = window.tracking.items["left"]
    assert sorted(points.symbols()) == ["o", "star"]  # the corrected vertex drawn apart


def test_an_instant_proposed_in_one_project_is_not_joined_in_the_next_one(qtbot, make_window, survey):
    """P's vertices all taken, then another project opened (the unfinished object discarded): an object
    measured there on the same frame stays an object of its own — the proposal was the previous project's
    object (the same id is another object here)."""
    path, object_id, fish, stereo = survey
    window = _open(qtbot, make_window, path, object_id, frame=12)
    ws = window.workspace
    qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_P)
    qtbot.waitUntil(lambda: ws.pick_tool.state.proposal is not None and not window.busy, timeout=30000)
    for _ in POINTS:
        qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_Return)  # Enter accepts
    assert len(ws.pick_tool.digitising.vertices) == 2 and "new instant" in _status(window)
    other = path.with_name(f"other_{path.name}")  # beside it: its video files found as in the first
    shutil.copy(path, other)  # another survey whose object of that id is another fish
    assert window.open_path(other, "drop")
    window.video.request(12)
    _wait_frame(qtbot, window, 12)
    project = ws.project
    ws.pick_tool.set_tool("line")
    for point in POINTS:
        left, right = truth(stereo, fish, 12, point * fish.length)
        ws.pick_tool.pick("left", tuple(left))
        ws.pick_tool.pick("right", tuple(right))
        if ws.pick_tool.state.pending is not None:  # held by a guard rail: keep it
            ws.pick_tool.accept_proposal()
    new = ws.pick_tool.finish_object("fish", "")
    qtbot.wait(50)  # a join is made after the store has finished (a zero-time timer)
    assert project.instants(object_id) == [] and project.instant_links() == {}
    assert new in ws.cache and "instant" not in _status(window)


def test_proposals_taken_then_undone_leave_the_next_object_measured_on_the_frame_its_own(qtbot, make_window, survey):
    """P's vertices all taken, then undone (Ctrl+Z each): another fish measured by hand on the same frame is
    not the proposed object's instant — only the vertices taken from the proposals are."""
    path, object_id, fish, stereo = survey
    window = _open(qtbot, make_window, path, object_id, frame=12)
    ws = window.workspace
    qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_P)
    qtbot.waitUntil(lambda: ws.pick_tool.state.proposal is not None and not window.busy, timeout=30000)
    for _ in POINTS:
        qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_Return)  # Enter accepts
    assert len(ws.pick_tool.digitising.vertices) == 2
    while ws.pick_tool.digitising.vertices:
        ws.undo.undo()
    ws.pick_tool.set_tool("line")
    for point in POINTS:  # another fish, 40 px away
        left, right = truth(stereo, fish, 12, point * fish.length)
        ws.pick_tool.pick("left", tuple(left + 40.0))
        ws.pick_tool.pick("right", tuple(right + 40.0))
        if ws.pick_tool.state.pending is not None:  # held by a guard rail: keep it
            ws.pick_tool.accept_proposal()
    new = ws.pick_tool.finish_object("another fish", "")
    qtbot.wait(50)  # a join is made after the store has finished (a zero-time timer)
    assert ws.project.instants(object_id) == [] and new in ws.cache


def test_undoing_stored_instants_over_another_annotators_later_edit_is_refused_and_deletes_nothing(
        qtbot, make_window, survey):
    """Ctrl+T's instants, then another annotator edits one of them (a second handle on the same project):
    Ctrl+Z is refused in one line naming the object, and every instant and the edit stay."""
    path, object_id, fish, stereo = survey
    window = _open(qtbot, make_window, path, object_id)
    qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_T)
    qtbot.waitUntil(lambda: window.tracking.model.complete and not window.busy, timeout=30000)
    ids = window.tracking.store_instants("4")
    assert len(ids) == 4
    with Project.open(path) as other:
        other.update_object(ids[1], notes="checked by bob")
    window.undo()
    project = window.workspace.project
    assert project.instants(object_id) == ids and project.object(ids[1]).notes == "checked by bob"
    assert str(ids[1]) in _status(window) and "someone else" in _status(window)
