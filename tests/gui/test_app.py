"""``usvips open`` and ``usvips`` with no arguments start the window; bad paths fail before Qt loads.

Each run is a separate process: ``main`` runs the application's event loop to its end, as a user's
session does.
"""

import json
import subprocess
import sys

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
