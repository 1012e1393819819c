"""The window starts without pyqtgraph (nor the calibration's model): the stereo panes are plain Qt and
every plot imports pyqtgraph when it is first made (importing it costs about half a second of CPU; the
window's whole start-up budget is 0.5 s, see ``usvips bench --only startup``), nor what a pair does not
need (the instants dialog, the adjustment engine, the tracker); its Qt-free modules come before Qt (PySide's
import hook reads the source of every module named after it, ``usvips.gui.start``). Checked in a fresh
interpreter, through the start-up probe's own path: ``usvips open SAMPLE`` with ``USVIPS_QUIT_WHEN_READY``
— the window shown, the sample opened (its project file made by a first start), its first pair drawn."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from usvips.locations import sample_project

_SCRIPT = """
import json, os, sys
blas_spin = []  # OPENBLAS_THREAD_TIMEOUT as numpy (and its OpenBLAS) is first imported
class Spy:
    def find_spec(self, name, path=None, target=None):
        if name == "numpy" and not blas_spin:
            blas_spin.append(os.environ.get("OPENBLAS_THREAD_TIMEOUT"))
sys.meta_path.insert(0, Spy())
from usvips.cli import main
code = main(["open", sys.argv[1]])
files = {name: getattr(module, "__file__", None) for name, module in sys.modules.items()}
print(json.dumps({"code": code, "modules": list(sys.modules), "files": files, "blas_spin": blas_spin}))
"""


@pytest.fixture(scope="module")
def started(tmp_path_factory) -> dict:
    """What a start of the window on a copy of the sample imported, in the order it did (the script's report)."""
    folder = tmp_path_factory.mktemp("start")
    sample = shutil.copytree(sample_project("tank_system1"), folder / "tank_system1")
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", USVIPS_QUIT_WHEN_READY="1",
               XDG_CONFIG_HOME=str(folder / "config"), XDG_DATA_HOME=str(folder / "data"))
    env.pop("OPENBLAS_THREAD_TIMEOUT", None)  # as a user's start has it
    for _ in range(2):  # the first open makes the sample's project file; the second is a user's next start
        result = subprocess.run([sys.executable, "-c", _SCRIPT, str(sample)], capture_output=True, text=True,
                                env=env, timeout=300, check=False)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "ready, pair" in result.stderr  # the pair was drawn before the check
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["code"] == 0
    return report


def test_the_window_is_shown_with_a_sample_pair_drawn_without_importing_pyqtgraph(started):
    loaded = set(started["modules"])
    assert "PySide6.QtWidgets" in loaded  # the window was made in this interpreter
    assert not {name for name in loaded if name.split(".")[0] == "pyqtgraph"}
    # nor the calibration's model and uncertainty (needed to measure, not to show a pair), nor the video
    # machinery and the tracker (a project of image pairs)
    assert not loaded & {"usvips.core.calibration.model", "usvips.core.calibration.uncertainty",
                         "usvips.app.video_project", "usvips.io.video_proxy", "usvips.app.tracking"}


def test_the_windows_qt_free_modules_are_imported_before_qt(started):
    # PySide's import hook reads the whole source of every module named after PySide6 was imported
    # (usvips.gui.start): the Qt-free modules come first, so that only the few Qt modules name are read
    order = started["modules"]
    after_qt = order[order.index("PySide6"):]
    qt_free = [name for name in after_qt if name.startswith("usvips.") and started["files"][name]
               and "PySide6" not in Path(started["files"][name]).read_text(encoding="utf-8")]
    assert len(qt_free) <= 5, qt_free


def test_the_instants_dialog_and_the_adjustment_engine_are_not_imported_at_start(started):
    # the instants dialog and its model are made when first shown; reading the pair's calibration file
    # needs the parameters' statuses (usvips.core.parameter_status), not the adjustment that estimates them
    loaded = set(started["modules"])
    assert not loaded & {"usvips.gui.qt.instants_view", "usvips.gui.instants_model", "usvips.core.adjustment",
                         "usvips.core.normal_equations"}


def test_the_media_files_hashing_is_not_imported_at_start(started):
    # hashlib (OpenSSL's binding) is imported by the store where a media file's hash is computed, when it is
    assert "hashlib" not in set(started["modules"])


def test_the_tracker_is_not_imported_at_start(started):
    # the tracking controls and their (empty) model are made with the window; the tracker, its
    # intersection and the statistics it imports come when something is first tracked
    assert not set(started["modules"]) & {"usvips.core.tracking", "usvips.core.intersection"}


def test_openblas_threads_busy_wait_briefly_in_the_window(started):
    # numpy's OpenBLAS (and OpenCV's) start a thread per further core that busy-waits 0.1 s of CPU for work
    # after it is made: the window's start sets the wait short before numpy is loaded (usvips.cli.brief_blas_spin)
    assert started["blas_spin"] == ["20"]
