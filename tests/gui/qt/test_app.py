"""``usvips open`` and ``usvips`` with no arguments start the window; bad paths fail before Qt loads.

Each run is a separate process: ``main`` runs the application's event loop to its end, as a user's
session does.
"""

import json
import subprocess
import sys

import pytest

#: Runs ``usvips`` with the given arguments and, once the window has settled, prints what it shows.
PROBE = """
import json, sys
from PySide6 import QtCore, QtWidgets
from usvips.cli import main
app = QtWidgets.QApplication(sys.argv[:1])
seen = {}
def inspect():
    windows = [w for w in QtWidgets.QApplication.topLevelWidgets()
               if w.objectName() == "usvips_main" and w.isVisible()]
    seen["windows"] = len(windows)
    for window in windows:
        if window.busy or (len(sys.argv) > 1 and window.workspace.pair is None):
            QtCore.QTimer.singleShot(50, inspect)
            return
        seen["pair"] = window.workspace.pair
        seen["title"] = window.windowTitle()
        window.close()
    QtWidgets.QApplication.quit()
QtCore.QTimer.singleShot(200, inspect)
seen["code"] = main(sys.argv[1:])
print(json.dumps(seen))
"""


def _probe(tmp_path, *argv: str) -> dict:
    env = {"XDG_CONFIG_HOME": str(tmp_path / "config"), "QT_QPA_PLATFORM": "offscreen",
           "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    result = subprocess.run([sys.executable, "-c", PROBE, *argv], capture_output=True, text=True, env=env,
                            timeout=120)
    assert result.returncode == 0, result.stderr[-2000:]
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_open_with_a_missing_project_is_one_line_and_loads_no_qt(tmp_path):
    code = ("import sys; from usvips.cli import main; code = main(['open', sys.argv[1]]);"
            "print(code, any(m.startswith('PySide6') for m in sys.modules))")
    result = subprocess.run([sys.executable, "-c", code, str(tmp_path / "nope.usvips")], capture_output=True,
                            text=True)
    assert result.stdout.split() == ["2", "False"]
    assert result.stderr.strip().count("\n") == 0 and "nope.usvips" in result.stderr


def test_open_starts_the_window_on_a_sample(tmp_path, sample_copy):
    directory = sample_copy("rov_flatport")
    seen = _probe(tmp_path, "open", str(directory))
    assert seen["code"] == 0 and seen["windows"] == 1 and seen["pair"] == "air1"
    assert "project.usvips" in seen["title"]
    assert (directory / "project.usvips").is_file()


def test_open_shows_the_pair_asked_for(tmp_path, sample_copy):
    seen = _probe(tmp_path, "open", str(sample_copy("tank_system1")), "--pair", "measure1")
    assert seen["code"] == 0 and seen["pair"] == "measure1"


def test_no_arguments_starts_an_empty_window(tmp_path):
    seen = _probe(tmp_path)
    assert seen["code"] == 0 and seen["windows"] == 1 and seen.get("pair") is None


def test_an_unexpected_exception_is_logged_and_shown_as_one_sentence(make_window, tmp_path, monkeypatch):
    """A bug: its traceback goes to the log file and the log panel, the window shows one sentence."""
    import usvips.gui.qt.error_report as app_module

    monkeypatch.setattr(app_module, "log_path", lambda: tmp_path / "data" / "usvips.log")
    window = make_window()
    try:
        {}["missing"]
    except KeyError as error:
        sentence = app_module.report_unexpected(type(error), error, error.__traceback__)
    assert "\n" not in sentence and "KeyError" in sentence and "usvips.log" in sentence
    assert window.statusBar().currentMessage() == sentence
    assert "Traceback" in window.log.toPlainText()
    assert "Traceback" in (tmp_path / "data" / "usvips.log").read_text()


@pytest.mark.qt_no_exception_capture
def test_an_exception_in_a_qt_slot_reaches_the_handler_and_the_window_stays(qtbot, make_window, tmp_path,
                                                                             monkeypatch):
    from PySide6 import QtCore

    import usvips.gui.qt.error_report as app_module

    monkeypatch.setattr(app_module, "log_path", lambda: tmp_path / "usvips.log")
    monkeypatch.setattr(sys, "excepthook", sys.excepthook)     # restored after the test
    window = make_window()
    app_module.install_error_handler()

    def broken_slot():
        raise ZeroDivisionError("a bug in a slot")

    QtCore.QTimer.singleShot(0, broken_slot)
    qtbot.waitUntil(lambda: "a bug in a slot" in window.statusBar().currentMessage(), timeout=10000)
    assert "ZeroDivisionError" in (tmp_path / "usvips.log").read_text()
    assert window.isVisible()


def test_an_expected_error_in_a_handler_is_its_own_line(make_window, tmp_path, monkeypatch):
    import usvips.gui.qt.error_report as app_module
    from usvips.core.errors import UsvipsError

    monkeypatch.setattr(app_module, "log_path", lambda: tmp_path / "usvips.log")
    window = make_window()
    error = UsvipsError("p.usvips: cannot write the project: the disk is full")
    assert app_module.report_unexpected(UsvipsError, error, None) == str(error)
    assert window.statusBar().currentMessage() == str(error) and not (tmp_path / "usvips.log").exists()
