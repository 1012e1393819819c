"""The display enhancement, Qt-free: saved per image (its stored path), read back when the pair is shown,
each change one undoable step, a damaged saved pipeline ignored with a warning; another project gets a
new model (nothing carried over)."""

from usvips.core.enhance import Pipeline
from usvips.gui.enhancement_model import Enhancement
from usvips.gui.signals import Signal
from usvips.gui.undo import UndoStack
from usvips.gui.workspace import Workspace
from usvips.store import Project


def test_pipelines_are_saved_per_image_undone_and_a_damaged_one_is_ignored(tmp_path):
    with Project.create(tmp_path / "p.usvips") as project:
        undo, changed, message = UndoStack(), Signal(), Signal()
        heard = []
        changed.connect(heard.append)
        message.connect(lambda level, text: heard.append((level, text)))
        model = Enhancement(undo, changed, message)
        model.load(project, {"left": "a/left.png", "right": "a/right.png"})
        clahe = Pipeline().then("clahe", clip_limit=2.0)
        model.set_pipelines({"left": clahe, "right": clahe})
        assert heard == ["left", "right"] and Pipeline.from_json(project.enhancement("a/right.png")) == clahe
        undo.undo()
        assert model.pipelines["left"] == Pipeline() and project.enhancement("a/left.png") == Pipeline().to_json()
        undo.redo()
        project.set_enhancement("b/left.png", "{not json")
        again = Enhancement(UndoStack(), Signal(), message)
        again.load(project, {"left": "b/left.png", "right": "a/right.png"})
        assert again.pipelines["left"] == Pipeline() and again.pipelines["right"] == clahe
        assert heard[-1][0] == "warning" and "left image is ignored" in heard[-1][1]
        model.set_pipelines({"left": clahe})  # no change: no step
        assert undo.undo_label == "enhancement (left and right)"


def test_another_project_gets_a_new_enhancement_model(tmp_path):
    ws = Workspace()
    ws.open_project(Project.create(tmp_path / "a.usvips"))
    first = ws.enhancement
    ws.open_project(Project.create(tmp_path / "b.usvips"))
    assert ws.enhancement is not first and ws.enhancement.pipelines == {"left": Pipeline(), "right": Pipeline()}
    ws.close_project()
