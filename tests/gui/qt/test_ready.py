"""The start-up probe (``USVIPS_QUIT_WHEN_READY=1``): the window quits once the project's first pair is
drawn, saying which, with exit codes for a project that does not open; and the window's imports leave out
the slow modules that showing a pair does not need (their CPU time is a row of ``usvips bench --only
startup``, not a timed test)."""

import json
import os
import shutil
import subprocess
import sys

import pytest

from usvips.gui.qt import ready
from usvips.locations import sample_project


def _open(tmp_path, *arguments: str, probe: str = "1") -> subprocess.CompletedProcess:
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", XDG_CONFIG_HOME=str(tmp_path / "config"),
               XDG_DATA_HOME=str(tmp_path / "data"), USVIPS_QUIT_WHEN_READY=probe)
    return subprocess.run([sys.executable, "-m", "usvips", "open", *arguments], capture_output=True, text=True,
                          env=env, timeout=300)


def test_the_window_quits_once_the_first_pair_is_drawn(tmp_path):
    sample = shutil.copytree(sample_project("tank_system1"), tmp_path / "sample")
    first = json.loads((sample / "project.json").read_text())["pairs"][0]["label"]
    result = _open(tmp_path, str(sample))
    assert result.returncode == 0, result.stderr
    assert f"{ready.ENVIRONMENT}: ready, pair {first!r} shown" in result.stderr
    chosen = json.loads((sample / "project.json").read_text())["pairs"][-1]["label"]
    result = _open(tmp_path, str(sample), "--pair", chosen)
    assert result.returncode == 0 and f"pair {chosen!r} shown" in result.stderr, result.stderr


def test_a_project_that_does_not_open_exits_with_code_4(tmp_path):
    broken = tmp_path / "broken.usvips"
    broken.write_bytes(b"not a project at all")
    result = _open(tmp_path, str(broken))
    assert result.returncode == 4, result.stderr
    assert "the project did not open" in result.stderr


def test_without_a_project_the_empty_window_is_ready(tmp_path):
    result = _open(tmp_path)
    assert result.returncode == 0 and "ready, no pair shown" in result.stderr, result.stderr


@pytest.mark.parametrize("value, wanted", [("1", True), ("yes", True), ("0", False), ("", False)])
def test_the_switch(monkeypatch, value, wanted):
    monkeypatch.setenv(ready.ENVIRONMENT, value)
    assert ready.wanted() is wanted
    monkeypatch.delenv(ready.ENVIRONMENT)
    assert ready.wanted() is False


def test_the_window_does_not_import_what_showing_a_pair_does_not_need():
    code = ("import sys\nimport usvips.gui.qt.main_window\nprint(sorted(m for m in sys.modules if m in "
            "{'scipy.stats', 'scipy.ndimage', 'scipy.linalg', 'scipy.optimize', 'scipy.signal', "
            "'usvips.core.calibration.phases'}), file=sys.stderr)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                            env=dict(os.environ, QT_QPA_PLATFORM="offscreen"))
    assert result.stderr.strip().splitlines()[-1] == "[]"


def test_the_window_loads_pyav_only_when_a_video_is_read():
    """PyAV (about a tenth of the window's start) is imported lazily: importing the window leaves it
    unexecuted (no ``av.error`` module); its first use loads it whole."""
    code = ("import sys\nimport usvips.gui.qt.main_window\nprint('av.error' in sys.modules, file=sys.stderr)\n"
            "from usvips.io import video_stream\nprint(video_stream.av.error.FFmpegError.__name__, "
            "'av.error' in sys.modules, file=sys.stderr)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                            env=dict(os.environ, QT_QPA_PLATFORM="offscreen"))
    assert result.stderr.strip().splitlines()[-2:] == ["False", "FFmpegError True"]


#: what the window's start, up to the first pair drawn, must not import: SciPy (calibration, detection),
#: numba and its LLVM (the batch kernels), the server's client library, a detection model's runtime, the
#: calibration's phases; PyAV is only registered for loading (``av.error`` would mean it ran)
_NOT_AT_START = ("scipy", "numba", "llvmlite", "psycopg", "onnxruntime", "torch", "av.error",
                 "usvips.core.calibration.phases")


def test_the_whole_start_to_a_drawn_pair_leaves_the_heavy_modules_unloaded(tmp_path):
    """The start as the bench's row times it (``usvips open`` with the probe, up to the first pair drawn):
    none of :data:`_NOT_AT_START` is in ``sys.modules`` afterwards, so an eager import added anywhere on
    that path (the window, its docks, the store, the first pair's reading and drawing) fails here."""
    sample = shutil.copytree(sample_project("tank_system1"), tmp_path / "sample")
    code = ("import sys\nfrom usvips.cli import main\ncode = main(['open', sys.argv[1]])\n"
            f"loaded = sorted(m for m in sys.modules if m.startswith({_NOT_AT_START!r}))\n"
            "print('loaded', loaded, file=sys.stderr)\nsys.exit(code)\n")
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", XDG_CONFIG_HOME=str(tmp_path / "config"),
               XDG_DATA_HOME=str(tmp_path / "data"), USVIPS_QUIT_WHEN_READY="1")
    result = subprocess.run([sys.executable, "-c", code, str(sample)], capture_output=True, text=True, env=env,
                            timeout=300)
    assert result.returncode == 0 and "ready, pair" in result.stderr, result.stderr
    assert result.stderr.strip().splitlines()[-1] == "loaded []", result.stderr
