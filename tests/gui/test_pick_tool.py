"""The pick tool (usvips.gui.pick_tool) on its own, without Qt and without a workspace: a small scene of a
random stereo rig behind a random housing, its two images and (where objects are stored) a real project.
Numbers are checked over many random rigs against the points the pixels were made from."""

import sys

import numpy as np
import pytest

from tests.core.scenes import HOUSINGS
from usvips.app.pair_geometry import placed
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import UsvipsError
from usvips.core.interior import Interior
from usvips.core.matching import EpipolarCurve
from usvips.core.measurements import QualityRules
from usvips.core.pointing import WeakMatch
from usvips.core.rig import RelativeOrientation, StereoRig
from usvips.core.stereo_calibration import StereoCalibration
from usvips.gui.calculator import Result
from usvips.gui.pick_tool import PickEvents, PickSettings, PickState, PickTool
from usvips.gui.signals import Signal
from usvips.gui.undo import UndoStack
from usvips.store import Project

WIDTH, HEIGHT = 1280, 960
#: the housings of the random rigs (the general implicit surface is left to the core's own tests: slow)
KINDS = ("air", "flat-port", "dome-cover", "dome-port")


def random_calibration(rng: np.random.Generator, sigma0_px: float = 0.5) -> StereoCalibration:
    """A random rig: interior, housing, baseline and convergence drawn; no calibration covariance (the
    vertices' covariance is then the pointing precision ``sigma0_px`` alone)."""
    housing = HOUSINGS[str(rng.choice(KINDS))]
    interiors = [Interior(f=rng.uniform(900, 1400), xp=WIDTH / 2 + rng.normal(0, 8), yp=HEIGHT / 2 + rng.normal(0, 8),
                          k1=rng.normal(0, 0.05), k2=rng.normal(0, 0.01)) for _ in range(2)]
    left = Camera(interiors[0], Exterior(0, 0, 0), housing, WIDTH, HEIGHT)
    right = Camera(interiors[1], Exterior(0, 0, 0), housing, WIDTH, HEIGHT)
    relative = RelativeOrientation(rng.uniform(0.2, 0.6), rng.normal(0, 0.01), rng.normal(0, 0.01),
                                   rng.normal(0, 0.02), rng.uniform(-0.12, 0.0), rng.normal(0, 0.02))
    rig = StereoRig.from_relative(left, right, relative)
    return StereoCalibration.from_cameras(rig.left, rig.right, "water", sigma0_px)


def true_pixels(rng: np.random.Generator, calibration: StereoCalibration, n: int):
    """``n`` random points 1-5 m in front of the rig (rig frame, m) seen well inside both images, and their
    exact pixels (N, 2) on the left and right."""
    rig = calibration.rig(0, "rig")
    left = np.column_stack([rng.uniform(60, WIDTH - 60, 8 * n), rng.uniform(60, HEIGHT - 60, 8 * n)])
    bundle = rig.left.rays(left)
    points = bundle.origins + rng.uniform(1.0, 5.0, (8 * n, 1)) * bundle.directions
    right = rig.right.project(points)
    inside = bundle.ok & right.ok & np.all((right.pixels > 30) & (right.pixels < [WIDTH - 30, HEIGHT - 30]), axis=1)
    index = np.flatnonzero(inside)[:n]
    assert index.size == n
    return points[index], left[index], right.pixels[index]


class Scene:
    """What the pick tool measures on (usvips.gui.pick_tool.PickScene): one pair ``dive`` of a random rig,
    blank or given images, a project when objects are stored. Its stored objects are read from the
    project directly (the workspace's object cache is tested in test_workspace*)."""

    def __init__(self, calibration: StereoCalibration | None, project: Project | None = None,
                 images: dict[str, np.ndarray] | None = None) -> None:
        self.project = project
        self.pair = "dive"
        self.images = images or {side: np.zeros((HEIGHT, WIDTH), np.uint8) for side in ("left", "right")}
        calibration_id = (project.add_calibration("c", {"phase": "water", "sigma0_px": 0.5}) if project is not None
                          else 1)
        self.geometry = None if calibration is None else placed(calibration, calibration_id, "dive")
        self.video_frame = None
        self.rules = QualityRules()
        self.undo = UndoStack()
        self.message = Signal()
        self.messages: list[tuple[str, str]] = []
        self.message.connect(lambda level, text: self.messages.append((level, text)))
        self.changes: list[tuple] = []

    def stored_object(self, object_id: int):
        return self.project.object(object_id)

    def objects_changed_in_store(self, added=(), updated=(), removed=()) -> None:
        self.changes.append((added, updated, removed))

    def figures(self, object_ids) -> Result:
        return Result((), (), "figures are the object cache's")

    def edit_stored(self, label, object_id, edit, then=None) -> None:
        from usvips.gui.undo import Command

        before = self.project.object_rows(object_id)
        after: list = []

        def redo() -> None:
            if after:
                self.project.put_back(after[0], replace=True)
            else:
                edit(before.modified)  # the version read, as the workspace hands it over
                after.append(self.project.object_rows(object_id))
            if then is not None:
                then()

        def undo() -> None:
            self.project.put_back(before, replace=True)
            if then is not None:
                then()

        self.undo.push(Command(label, redo, undo))


def make_tool(calibration, project=None, images=None, **settings) -> tuple[PickTool, Scene]:
    scene = Scene(calibration, project, images)
    return PickTool(scene, PickEvents(), PickSettings(**settings)), scene


def test_the_pick_tool_loads_no_qt():
    import subprocess

    code = ("import sys, usvips.gui.pick_tool;"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in {'PySide6', 'shiboken6', 'pyqtgraph'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_proposed_vertices_over_random_rigs_land_on_the_truth_within_their_covariance():
    """Noisy picks of known points, proposed and kept by Enter: the squared error normalised by the
    vertex's covariance averages 1 per coordinate (chi-square, 3 per point), and the first pick's epipolar
    curve passes the true conjugate."""
    rng = np.random.default_rng(27)
    sigma = 0.5
    normalised, off_curve = [], []
    for _ in range(40):
        calibration = random_calibration(rng, sigma)
        tool, scene = make_tool(calibration, auto_match=False)
        points, left, right = true_pixels(rng, calibration, 10)
        for point, true_left, true_right in zip(points, left, right, strict=True):
            noisy_left, noisy_right = true_left + rng.normal(0, sigma, 2), true_right + rng.normal(0, sigma, 2)
            tool.propose_vertex(noisy_left, noisy_right, "from a track")
            state = tool.state
            assert state.source == "left" and state.proposal == tuple(noisy_right) and "from a track" in state.note
            off_curve.append(EpipolarCurve(state.curve, np.zeros(len(state.curve))).distance_to(true_right))
            tool.accept_proposal()
            vertex = tool.last_point
            assert tool.state.source is None and vertex.left == tuple(noisy_left) and vertex.right == tuple(noisy_right)
            assert vertex.flags == () and vertex.weak is None  # a proposal not marked weak is kept unflagged
            error = vertex.xyz - point
            normalised.append(error @ np.linalg.solve(vertex.covariance, error) / 3)
    # 400 points, 1200 degrees of freedom: the mean lies within ±0.15 of 1 with probability > 0.999
    assert 0.85 < np.mean(normalised) < 1.15, np.mean(normalised)
    # the curve is drawn through the noisy left pick: the true conjugate lies within a few sigma of it
    assert np.quantile(off_curve, 0.99) < 6 * sigma, np.quantile(off_curve, 0.99)


def test_a_vertex_kept_from_a_weak_proposal_is_flagged_and_the_flag_is_stored_with_the_vertex(tmp_path):
    """Two unrelated noise images: auto-match refuses every candidate (the correlation is low) yet proposes
    the best one, weak; Enter keeps it, and the stored vertex carries the matcher's score and reason as a
    fact (not the notes: a later notes edit keeps it), with the source "auto-match". A click that corrects
    the proposal instead is the user's own pick: a hand click, no such flag."""
    rng = np.random.default_rng(5)
    project = Project.create(tmp_path / "p.usvips")
    project.add_pair("dive")
    images = {side: rng.integers(0, 255, (HEIGHT, WIDTH)).astype(np.uint8) for side in ("left", "right")}
    calibration = random_calibration(rng)
    tool, scene = make_tool(calibration, project, images)
    _, left, right = true_pixels(rng, calibration, 3)
    tool.set_tool("line")
    scores = []
    for k in range(2):
        tool.pick("left", left[k])
        state = tool.state
        assert state.proposal is not None and state.weak, state.note
        assert "weak proposal (correlation" in state.note and state.weak_reason.startswith("score ")
        scores.append(state.weak_match.score)
        tool.accept_proposal()
        if tool.state.pending is not None:  # a guard rail held it too: Enter again keeps it
            tool.accept_proposal()
        vertex = tool.digitising.vertices[-1]
        assert vertex.weak == state.weak_match and vertex.source == "auto-match"
        assert f"{state.weak_reason}".startswith(f"score {vertex.weak.score:.2f}: {vertex.weak.reason}")
        assert not any("weak" in flag for flag in vertex.flags)  # a fact of the vertex, not a guard rail's note
        assert tool.digitising.vertices[-1].right == state.proposal
    tool.pick("left", left[2])
    assert tool.state.weak
    tool.pick("right", right[2])  # the user clicks the point: a correction, not an accepted proposal
    if tool.state.pending is not None:
        tool.accept_proposal()
    assert tool.digitising.vertices[-1].weak is None and tool.digitising.vertices[-1].source == "hand click"
    object_id = tool.finish_object("cod")
    stored = project.object(object_id)
    assert "weak" not in stored.notes
    assert [v.weak.score if v.weak else None for v in stored.vertices] == [*scores, None]
    assert [v.source for v in stored.vertices] == ["auto-match", "auto-match", "hand click"]
    project.update_object(object_id, notes="checked by a colleague")  # no edit of notes removes it
    assert [v.weak is not None for v in project.object(object_id).vertices] == [True, True, False]


def test_a_weak_proposal_put_by_propose_vertex_is_flagged_with_its_note():
    rng = np.random.default_rng(8)
    calibration = random_calibration(rng)
    tool, _ = make_tool(calibration, auto_match=False)
    _, left, right = true_pixels(rng, calibration, 1)
    tool.propose_vertex(left[0], right[0], "track 4 predicted, 2 frames ahead", weak=True)
    assert tool.state.weak
    tool.accept_proposal()
    assert tool.last_point.weak == WeakMatch(None, "track 4 predicted, 2 frames ahead")
    assert tool.last_point.flags == () and tool.last_point.source == "tracked"  # a track's pixels


def test_propose_vertex_refuses_pixels_outside_and_works_without_a_calibration():
    rng = np.random.default_rng(3)
    tool, scene = make_tool(random_calibration(rng))
    with pytest.raises(UsvipsError, match=r"outside the right image \(1280 × 960 px\)"):
        tool.propose_vertex((10.0, 10.0), (1400.0, 10.0), "track")
    with pytest.raises(UsvipsError, match="left pixel is two numbers"):
        tool.propose_vertex("here", (10.0, 10.0), "track")
    assert tool.state == PickState() and scene.undo.undo_label is None  # nothing changed
    bare, scene = make_tool(None)
    bare.propose_vertex((100.0, 120.0), (90.0, 121.0), "track 1")
    assert bare.state.left == (100.0, 120.0) and bare.state.proposal == (90.0, 121.0) and bare.state.curve is None
    bare.accept_proposal()  # no calibration: said, the first pick stands
    assert "no active calibration" in scene.messages[-1][1] and bare.state.left == (100.0, 120.0)


@pytest.mark.parametrize("seed", range(4))
def test_undo_and_redo_of_any_sequence_of_steps_restore_the_very_state(seed):
    """Random picks, proposals, nudges, Enter and Esc on a random rig with the line tool: after each
    step the (state, vertices, last point) is recorded; undo walks back through every one of them, the
    very objects, and redo forward again."""
    rng = np.random.default_rng(100 + seed)
    calibration = random_calibration(rng)
    tool, scene = make_tool(calibration, auto_match=False)
    tool.set_tool("line")
    _, left, right = true_pixels(rng, calibration, 12)
    seen = [(tool.state, tool.digitising.vertices, tool.last_point)]

    def record() -> None:  # after every step pushed (not after undo/redo)
        if len(scene.undo._done) == len(seen):
            seen.append((tool.state, tool.digitising.vertices, tool.last_point))

    scene.undo.changed.connect(record)
    for _ in range(30):
        k = int(rng.integers(0, len(left)))
        action = int(rng.integers(0, 6))
        try:
            if action == 0:
                tool.pick(str(rng.choice(["left", "right"])), left[k] if rng.random() < 0.5 else right[k])
            elif action == 1:
                tool.propose_vertex(left[k], right[k] + rng.normal(0, 0.3, 2), "track")
            elif action == 2:
                tool.nudge(*rng.choice([-0.1, 0.1, 1.0], 2))
            elif action == 3:
                tool.accept_proposal()
            elif action == 4:
                tool.cancel_vertex()
            else:
                tool.pick("left", left[k])
                tool.pick("right", right[k] + rng.normal(0, 0.3, 2))
        except UsvipsError:
            continue  # refused by name (nothing to nudge or accept): nothing changed
    scene.undo.changed.disconnect(record)
    assert len(seen) == len(scene.undo._done) + 1 and len(seen) > 12
    history = seen
    for expected in reversed(history[:-1]):
        scene.undo.undo()
        assert tool.state is expected[0] and tool.digitising.vertices is expected[1]
        assert tool.last_point is expected[2]
    for expected in history[1:]:
        scene.undo.redo()
        assert tool.state is expected[0] and tool.digitising.vertices is expected[1]
        assert tool.last_point is expected[2]


def test_a_pick_off_the_curve_is_held_and_enter_keeps_it_flagged(tmp_path):
    rng = np.random.default_rng(11)
    calibration = random_calibration(rng)
    project = Project.create(tmp_path / "p.usvips")
    project.add_pair("dive")
    tool, scene = make_tool(calibration, project, auto_match=False, max_off_curve_px=3.0)
    _, left, right = true_pixels(rng, calibration, 1)
    tool.set_tool("point")
    tool.pick("left", left[0])
    curve = EpipolarCurve(tool.state.curve, np.zeros(len(tool.state.curve)))
    tangent = curve.pixels[-1] - curve.pixels[0]
    normal = np.array([-tangent[1], tangent[0]]) / np.linalg.norm(tangent)
    tool.pick("right", right[0] + 12 * normal)
    assert tool.state.pending is not None and "off the epipolar curve (> 3 px)" in scene.messages[-1][1]
    assert project.objects() == []  # held: nothing stored
    tool.accept_proposal()
    (stored,) = project.objects()
    assert stored.kind == "point" and "flagged: vertex 1: the right pick is" in stored.notes


def test_storing_and_re_picking_are_undone_to_the_very_rows(tmp_path):
    """A fish stored, undone and redone comes back under the same id; a re-picked vertex replaces the
    stored one and undo restores the rows exactly."""
    rng = np.random.default_rng(21)
    calibration = random_calibration(rng)
    project = Project.create(tmp_path / "p.usvips")
    project.add_pair("dive")
    tool, scene = make_tool(calibration, project, auto_match=False)
    stored_ids = []
    tool.events.stored.connect(stored_ids.append)
    _, left, right = true_pixels(rng, calibration, 3)
    tool.set_tool("line")
    for k in range(2):
        tool.propose_vertex(left[k], right[k], "track")
        tool.accept_proposal()
    object_id = tool.finish_object("cod", "by the reef")
    assert stored_ids == [object_id] and tool.digitising.vertices == () and tool.state == PickState()
    rows = project.object_rows(object_id)
    scene.undo.undo()
    assert project.objects() == [] and len(tool.digitising.vertices) == 2  # the picks are back
    scene.undo.redo()
    assert project.object_rows(object_id) == rows and stored_ids == [object_id]  # same id, not stored anew
    tool.start_repick(object_id, 1)
    assert tool.repick == (object_id, 1)
    tool.propose_vertex(left[2], right[2], "track")
    tool.accept_proposal()
    assert tool.repick is None
    moved = project.object(object_id).vertices[1]
    assert (moved.xl, moved.yl) == tuple(left[2])
    scene.undo.undo()
    assert project.object_rows(object_id) == rows
    with pytest.raises(UsvipsError, match="has vertices 1 to 2, not 3"):
        tool.start_repick(object_id, 2)


def test_another_project_gets_a_new_pick_tool_with_the_settings_kept(tmp_path):
    from usvips.gui.workspace import Workspace

    ws = Workspace()
    projects = [Project.create(tmp_path / f"{name}.usvips") for name in "ab"]
    ws.open_project(projects[0])
    first = ws.pick_tool
    ws.pick_tool.set_tool("polygon")
    ws.settings.snap, ws.settings.auto_match, ws.pick_tool.attribute = True, False, "cod"
    heard = []
    ws.picks_changed.connect(lambda: heard.append("picks"))
    ws.open_project(projects[1])
    assert ws.pick_tool is not first and ws.pick_tool.scene is ws
    tool = ws.pick_tool
    assert tool.attribute == "" and tool.last_point is None and tool.repick is None and tool.state == PickState()
    assert tool.tool == "polygon" and ws.settings.snap and not ws.settings.auto_match  # the user's, not the project's
    assert heard == ["picks"]  # the views hear the new tool through the same events
    ws.close_project()
