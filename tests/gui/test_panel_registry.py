"""Panels are contributed, not wired into the window: a panel declared in one module (here, in this test)
and registered is built into a dock of the window, tabbed with its group, listed under View and handed
the workspace and the messaging service — with no edit to MainWindow."""

import pytest
from PySide6 import QtWidgets

from usvips.gui import panel_registry
from usvips.gui.panel_registry import Panel, register, unregister
from usvips.gui.window_context import WindowContext


class ProjectNamePanel(QtWidgets.QLabel):
    """A panel of this test: the open project's file name, and every error said in the window."""

    def __init__(self, context: WindowContext) -> None:
        super().__init__("no project")
        self.errors: list[str] = []
        self.cleaned = False
        context.workspace.project_changed.connect(
            lambda project: self.setText("no project" if project is None else project.path.name))
        context.messages.said.connect(lambda level, text: self.errors.append(text) if level == "error" else None)

    def cleanup(self) -> None:
        self.cleaned = True


@pytest.fixture
def project_name_panel():
    panel = register(Panel("project_name", "Project name", "bottom", ProjectNamePanel, group="records",
                           order=95))
    yield panel
    unregister(panel.id)


def test_a_panel_registered_in_one_module_is_a_dock_of_the_window(qtbot, make_window, sample_copy,
                                                                   project_name_panel):
    window = make_window()
    widget = window.panels["project_name"]
    dock = window.docks["project_name"]
    assert isinstance(widget, ProjectNamePanel)
    assert dock.windowTitle() == "Project name" and dock.objectName() == "dock_project_name"
    assert window.dockWidgetArea(dock) == window.dockWidgetArea(window.docks["objects"])
    assert dock in window.tabifiedDockWidgets(window.docks["objects"])  # tabbed with its group
    view = next(a.menu() for a in window.menuBar().actions() if a.text() == "&View")
    assert dock.toggleViewAction() in view.actions()
    # it hears the models and the messages, not the window
    assert window.open_path(sample_copy("rov_flatport"))
    assert widget.text() == window.workspace.project.path.name
    window.workspace.message.emit("error", "a model's error")
    assert widget.errors == ["a model's error"]
    window.close()
    assert widget.cleaned


def test_without_its_registration_the_panel_is_not_built(make_window):
    window = make_window()
    assert "project_name" not in window.panels
    assert set(window.panels) == {p.id for p in panel_registry.panels()}


def test_every_built_in_panel_is_declared_once_by_its_own_module():
    declared = {p.id: p for p in panel_registry.panels()}
    assert {"enhancement", "calculator", "planner", "objects", "observation", "plan", "log", "qa",
            "review"} <= set(declared)
    import importlib

    for module in panel_registry.BUILT_IN:
        panel = importlib.import_module(module).PANEL
        assert declared[panel.id] is panel
    assert len({p.title for p in declared.values()}) == len(declared)


def test_a_panel_declared_wrongly_is_refused():
    with pytest.raises(ValueError, match="area 'middle'"):
        Panel("somewhere", "Somewhere", "middle", ProjectNamePanel)
    with pytest.raises(ValueError, match="'Log' is panel 'log'"):
        panel_registry.panels()
        register(Panel("another_log", "Log", "bottom", ProjectNamePanel))
    with pytest.raises(ValueError, match="registered twice"):
        register(Panel("log", "Another log", "bottom", ProjectNamePanel))


def test_a_panel_behind_a_tab_is_made_when_its_dock_is_first_shown(qtbot, make_window, project_name_panel):
    """Start-up pays only for the panels on screen: one behind another tab is made when its dock comes to
    the front (here from the View menu's toggle), once; a panel made at start (the log) is there at once."""
    made = []
    panel = register(Panel("made_once", "Made once", "bottom",
                           lambda context: made.append(ProjectNamePanel(context)) or made[-1], group="records",
                           order=96))
    try:
        window = make_window()
        qtbot.wait(10)
        assert made == [] and not window.panels.is_built("made_once")
        assert window.panels.is_built("log") and window.panels.is_built("objects")  # at start; in front
        assert not window.panels.is_built("planner")  # behind the geo-calculator's tab
        dock = window.docks["made_once"]
        dock.toggleViewAction().trigger()  # View › Made once: closed (it was open, behind a tab)
        dock.toggleViewAction().trigger()  # and open again, in front
        dock.raise_()
        qtbot.waitUntil(lambda: window.panels.is_built("made_once"))
        assert len(made) == 1
        assert dock.widget().widget() is made[0] is window.panel("made_once")
        dock.hide()
        dock.show()
        assert len(made) == 1
    finally:
        unregister(panel.id)


def test_a_panel_asked_for_is_made_without_its_dock_shown(make_window, project_name_panel):
    window = make_window()
    assert not window.panels.is_built("project_name") and "project_name" in window.panels
    widget = window.panel("project_name")
    assert isinstance(widget, ProjectNamePanel) and window.panels.is_built("project_name")
    assert window.docks["project_name"].widget().widget() is widget
