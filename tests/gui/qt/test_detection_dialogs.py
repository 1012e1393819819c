"""Measure › Detect fish on this frame in a window: the remembered model is used, the run goes through the
window's worker, the proposals are stored unreviewed, each keypoint's 95 % circle is drawn on both panes and
review mode opens on them — with the dialogs handed the window's context, never the window."""

from tests.app.detection_scenes import make_project, scene, write_switching_model
from tests.gui.conftest import open_sample, review_circles, wait_for_pair
from usvips.gui.qt.detection_dialogs import SETTING


def _window_on_pair(qtbot, make_window, tmp_path):
    """A window showing the pair "dive" of a new project, a model of its scene remembered in the settings;
    the window and the model's description file."""
    truth = scene(seed=5)
    project = make_project(tmp_path)
    model = write_switching_model(tmp_path, truth, sigma=1.0)
    window = make_window()
    window.settings.setValue(SETTING, str(model))
    assert window.open_path(project)
    window.load_pair("dive")
    wait_for_pair(qtbot, window, "dive")
    return window, model


def test_detect_on_the_pair_shown_stores_draws_and_opens_review(qtbot, make_window, tmp_path):
    window, _ = _window_on_pair(qtbot, make_window, tmp_path)
    assert window.workspace.project.objects() == []

    window.actions["detect"].trigger()
    qtbot.waitUntil(lambda: not window.busy and len(window.workspace.project.objects()) == 3, timeout=20000)
    stored = window.workspace.project.objects()
    assert all(o.creator.startswith("model ") for o in stored)
    assert all(window.workspace.project.review(o.id) is None or window.workspace.project.review(o.id).state
               not in ("accepted", "flagged") for o in stored)
    # the run's results reach the window a step a turn (stored, shown, said, review mode opened)
    qtbot.waitUntil(lambda: window.docks["review"].isVisible() and sorted(window.review.model.queue)
                    == sorted(o.id for o in stored), timeout=5000)
    from usvips.gui.qt.detection_dialogs import _STATES
    circles = _STATES[id(window.workspace)].circles
    assert {side: len(item.points()) for side, item in circles.items.items()} == {"left": 6, "right": 6}
    # a handle on each keypoint in each image, made a few a turn; drawn again, the same handles are kept
    qtbot.waitUntil(lambda: len(circles.handles) == 12, timeout=5000)
    made = {key: handle for key, (handle, _) in circles.handles.items()}
    circles.draw()
    assert {key: handle for key, (handle, _) in circles.handles.items()} == made

    window.actions["detect"].trigger()  # again: the same fish are duplicates, nothing is added
    qtbot.waitUntil(lambda: not window.busy and "duplicate" in window.log.toPlainText(), timeout=20000)
    assert len(window.workspace.project.objects()) == 3


def test_the_model_is_loaded_by_the_worker_once_and_kept_as_the_projects_default(qtbot, make_window, tmp_path,
                                                                                   monkeypatch):
    """Loading a model runs its network once (0.15 s for the shipped one): the first Detect loads it on the
    worker, never on the window's thread, and the next Detect uses it as loaded."""
    from usvips.app.detection_model import project_model_path

    on_window_thread = _loads_recorded(monkeypatch)
    window, model = _window_on_pair(qtbot, make_window, tmp_path)
    window.actions["detect"].trigger()
    qtbot.waitUntil(lambda: not window.busy and len(window.workspace.project.objects()) == 3, timeout=20000)
    assert on_window_thread == [False]
    assert project_model_path(window.workspace.project) == model.resolve()  # the project's default now
    window.actions["detect"].trigger()
    qtbot.waitUntil(lambda: not window.busy and "duplicate" in window.log.toPlainText(), timeout=20000)
    assert on_window_thread == [False]  # the project's default is the model loaded: not loaded again


def _loads_recorded(monkeypatch) -> list[bool]:
    """Every model load from now on (by Detect's worker or by *Detection model…*), recorded as whether it ran
    on the window's thread."""
    import threading

    from usvips.gui import detect_model
    from usvips.gui.qt import detection_dialogs

    on_window_thread: list[bool] = []
    real = detect_model.load_model

    def recording(path):
        on_window_thread.append(threading.current_thread() is threading.main_thread())
        return real(path)

    monkeypatch.setattr(detect_model, "load_model", recording)
    monkeypatch.setattr(detection_dialogs, "load_model", recording)
    return on_window_thread


def test_without_a_chosen_model_detect_uses_the_shipped_one_without_asking(qtbot, make_window, tmp_path,
                                                                           monkeypatch):
    """As ``usvips detect``: no project default and none remembered — the model shipped with USVIPS is used
    (no file dialog opened in the project's folder, where it is not), and it does not become the project's
    default."""
    from PySide6 import QtWidgets

    from usvips.app.detection_model import bundled_model_path, project_model_path

    asked = []
    monkeypatch.setattr(QtWidgets.QFileDialog, "getOpenFileName", lambda *a, **k: asked.append(a) or ("", ""))
    window, _ = _window_on_pair(qtbot, make_window, tmp_path)
    window.settings.remove(SETTING)
    window.actions["detect"].trigger()
    qtbot.waitUntil(lambda: not window.busy and "looked at" in window.log.toPlainText(), timeout=30000)
    assert asked == []
    assert f"model {bundled_model_path().stem}" in window.log.toPlainText()
    assert project_model_path(window.workspace.project) is None


def test_proposals_stored_before_the_window_opened_get_their_handles_when_review_opens(qtbot, make_window,
                                                                                      tmp_path):
    """Proposals from ``usvips detect`` (or an earlier session): once the review panel is made, their 95 %
    circles and the handles that correct their keypoints are drawn, with no Detect run in this window —
    before, only a Detect made them, so a reviewer of a command-line run could not drag a keypoint."""
    from usvips.app.detection_model import load_model
    from usvips.app.detection_service import detect_in_project
    from usvips.store import Project

    truth = scene(seed=5)
    path = make_project(tmp_path)
    model = write_switching_model(tmp_path, truth, sigma=1.0)
    with Project.open(path) as project:
        assert len(detect_in_project(project, load_model(model), pair="dive").proposals) == 3
    window = make_window()
    open_sample(qtbot, window, path, "dive")
    circles = review_circles(qtbot, window)
    assert {side: len(item.points()) for side, item in circles.items.items()} == {"left": 6, "right": 6}
    qtbot.waitUntil(lambda: len(circles.handles) == 12, timeout=5000)


def test_detection_model_loads_on_the_worker_and_becomes_the_projects_default(qtbot, make_window, tmp_path,
                                                                             monkeypatch):
    """Measure › Detection model…: the file chosen in the dialog is loaded (its network run once) on the
    window's worker, never on the window's thread; once loaded it is the window's model, the project's
    default and the settings' remembered model."""

    from PySide6 import QtWidgets

    from usvips.app.detection_model import project_model_path
    from usvips.gui.qt import detection_dialogs

    window, model = _window_on_pair(qtbot, make_window, tmp_path)
    window.settings.remove(SETTING)
    on_window_thread = _loads_recorded(monkeypatch)
    monkeypatch.setattr(QtWidgets.QFileDialog, "getOpenFileName", lambda *a, **k: (str(model), ""))
    window.actions["detect_model"].trigger()
    qtbot.waitUntil(lambda: detection_dialogs.loaded_model(window.context) is not None and not window.busy,
                    timeout=20000)
    assert on_window_thread == [False]
    assert project_model_path(window.workspace.project) == model.resolve()
    assert window.settings.value(SETTING) == str(model)
    assert "loaded from" in window.log.toPlainText()
    window.actions["detect"].trigger()  # the model loaded is used: not loaded again
    qtbot.waitUntil(lambda: not window.busy and len(window.workspace.project.objects()) == 3, timeout=20000)
    assert on_window_thread == [False]


def test_a_file_that_is_no_model_is_named_and_changes_nothing(qtbot, make_window, tmp_path, monkeypatch):
    from PySide6 import QtWidgets

    from usvips.app.detection_model import project_model_path
    from usvips.gui.qt import detection_dialogs

    window, model = _window_on_pair(qtbot, make_window, tmp_path)
    bad = tmp_path / "not_a_model.toml"
    bad.write_text("input_size = [\n")
    monkeypatch.setattr(QtWidgets.QFileDialog, "getOpenFileName", lambda *a, **k: (str(bad), ""))
    window.actions["detect_model"].trigger()
    qtbot.waitUntil(lambda: not window.busy and "not_a_model.toml" in window.log.toPlainText(), timeout=20000)
    assert detection_dialogs.loaded_model(window.context) is None
    assert project_model_path(window.workspace.project) is None
    assert window.settings.value(SETTING) == str(model)  # the model remembered before is kept
    assert _loading(window) is None  # a Detect now uses the remembered model, not the bad file
    window.actions["detect"].trigger()
    qtbot.waitUntil(lambda: not window.busy and len(window.workspace.project.objects()) == 3, timeout=20000)


def test_a_detect_asked_while_the_model_loads_uses_that_model(qtbot, make_window, tmp_path, monkeypatch):
    """The chosen model is still loading when Detect is asked for: the run loads the chosen file (not the one
    remembered before, nor the shipped one) and makes it the project's default."""

    from usvips.app.detection_model import project_model_path
    from usvips.gui.qt import detection_dialogs

    window, remembered = _window_on_pair(qtbot, make_window, tmp_path)
    chosen = _another_model(tmp_path, "chosen")
    release = _loads_held_back(monkeypatch)
    assert detection_dialogs.choose_model(window.context, window, str(chosen))
    assert _loading(window) == str(chosen)
    window.actions["detect"].trigger()
    release.set()
    qtbot.waitUntil(lambda: not window.busy and len(window.workspace.project.objects()) == 3, timeout=30000)
    assert project_model_path(window.workspace.project) == chosen.resolve() != remembered.resolve()
    assert _loading(window) is None


def _loading(window):
    from usvips.gui.qt.detection_dialogs import _STATES

    return _STATES[id(window.workspace)].loading


def test_of_two_models_chosen_one_after_the_other_the_later_stands(qtbot, make_window, tmp_path, monkeypatch):
    """The first file chosen loads slowly, the second at once: when the first ends loading it is not adopted
    over the second (the later choice stands, as the window's model and the project's default)."""

    from usvips.app.detection_model import project_model_path
    from usvips.gui.qt import detection_dialogs

    window, first = _window_on_pair(qtbot, make_window, tmp_path)
    second = _another_model(tmp_path, "second")
    release = _loads_held_back(monkeypatch, only=first)
    qtbot.waitUntil(lambda: not window.busy, timeout=20000)  # the window's own start-up work done
    assert detection_dialogs.choose_model(window.context, window, str(first))
    assert detection_dialogs.choose_model(window.context, window, str(second))
    if window.pool.maxThreadCount() > 1:  # the second ends first (else they queue)
        qtbot.waitUntil(lambda: detection_dialogs.loaded_model(window.context) is not None, timeout=20000)
    release.set()
    qtbot.waitUntil(lambda: not window.busy and "another was chosen since" in window.log.toPlainText(),
                    timeout=20000)
    assert project_model_path(window.workspace.project) == second.resolve()
    assert _loading(window) is None and window.settings.value(SETTING) == str(second)
    assert detection_dialogs._session(window.context).is_loaded(str(second))


def _another_model(tmp_path, name: str):
    """A second description file of the same scene's model, in a folder of its own."""
    folder = tmp_path / name
    folder.mkdir()
    return write_switching_model(folder, scene(seed=5), sigma=1.0)


def _loads_held_back(monkeypatch, only=None):
    """*Detection model…*'s loads (of ``only``'s file, or of every file) wait until the event returned is set."""
    import threading

    from usvips.gui.qt import detection_dialogs

    release = threading.Event()
    real = detection_dialogs.load_model

    def held(path):
        if only is None or path == str(only):
            release.wait(20)
        return real(path)

    monkeypatch.setattr(detection_dialogs, "load_model", held)
    return release
