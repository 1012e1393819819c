"""Start-up: the CPU time (user + system, seconds, of the child process) that ``usvips --help`` and a
subcommand's ``--help`` take, against a bare ``python -c pass`` started the same way in the same run; and
the window's start to usable.

CPU time, not wall time, so that a loaded machine blurs it less (it still adds: the same start measured
0.40 s on a quiet machine and 0.62 s beside a package install, so each row gives the least of its runs,
the window's with the median of its :data:`WINDOW_STARTS` starts and the load beside it); the promises
are absolute (issue 27, item 7: ``target_s`` 0.3 s of CPU for the command line; issue 37: 0.5 s for the
window) and the ratio to a bare interpreter is given beside them.

The window's row runs ``python -m usvips open SAMPLE`` offscreen (``QT_QPA_PLATFORM=offscreen``) with
``USVIPS_QUIT_WHEN_READY=1`` (:mod:`usvips.gui.qt.ready`): the window is shown, a copy of the bundled sample
``tank_system1`` opened (its project file made by an untimed first open, as a user's second start finds
it), its first image pair read and drawn, and the process quits. Its settings and data folders are
temporary ones, so the user's are not touched. ``qt_window_cpu_s`` is what an empty ``QMainWindow`` shown
the same way costs (Qt's own floor); ``images_window_cpu_s`` what a window showing two 640 × 480 images read
with OpenCV in plain ``QGraphicsView`` widgets costs (the floor of what the panes are made with: Qt, numpy and
OpenCV's decoder); ``pyqtgraph_window_cpu_s`` the same two images in pyqtgraph views (what the panes cost
when they were made with pyqtgraph, which makes every Qt type and enum on import: the plots import it when
they are first made, never at the start).

The window's children run with their bytecode cached (``PYTHONPYCACHEPREFIX``, a temporary folder, written
by the untimed first run), as an installed package has it: with ``PYTHONDONTWRITEBYTECODE`` in the
environment every module of the package would be compiled from source on every start, about half a second
of CPU that no user pays. Nor do they inherit the bench's settings of what the libraries' threads do
(:data:`NOT_A_USERS`: thread counts of OpenBLAS and OpenMP, how long OpenBLAS's idle threads busy-wait) or
Python's tracing modes: the window's start is timed as a user's, with what ``usvips`` sets itself
(:func:`usvips.cli.brief_blas_spin`). The floors, which are not ``usvips`` commands, are given the same
brief busy-wait, so that they are the floors of the same start: with OpenBLAS's default each copy of it
(numpy's, OpenCV's) spins a thread for 0.1 s of CPU after it is loaded whenever a core is idle, which
swung the window's start between 0.5 and 0.8 s of CPU with what else the machine ran.
"""

from __future__ import annotations

import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

#: the CPU seconds a command-line start may take (``usvips --help``, ``usvips project --help``)
TARGET_CPU_S = 0.3
#: the CPU seconds the window may take from launch to usable (shown, project open, first pair drawn)
WINDOW_TARGET_CPU_S = 0.5
#: the window's starts timed at scale 1 (its CPU swings by a tenth of a second with what else the machine
#: runs: the least is the start's cost, the median beside it)
WINDOW_STARTS = 5
#: the bundled sample the window's row opens (image pairs, a calibration)
WINDOW_SAMPLE = "tank_system1"
#: environment variables the window's starts do not inherit from the bench: a user's start has none of them
#: (bytecode not written, the libraries' thread counts and busy-wait, Python's tracing and development modes)
NOT_A_USERS = ("PYTHONDONTWRITEBYTECODE", "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
               "OPENBLAS_THREAD_TIMEOUT", "PYTHONPROFILEIMPORTTIME", "PYTHONDEVMODE", "PYTHONTRACEMALLOC",
               "PYTHONMALLOC", "PYTHONVERBOSE")

_EMPTY_WINDOW = ("from PySide6 import QtWidgets\napp = QtWidgets.QApplication([])\nwindow = QtWidgets.QMainWindow()\n"
                 "window.show()\napp.processEvents()\nwindow.repaint()\n")
#: the toolkit's floor: a window of two pyqtgraph image views, each showing a 640 x 480 grey image
_PYQTGRAPH_WINDOW = ("import numpy as np\nimport pyqtgraph as pg\nfrom PySide6 import QtWidgets\n"
                     "app = QtWidgets.QApplication([])\nwindow = QtWidgets.QMainWindow()\n"
                     "views = pg.GraphicsLayoutWidget()\nwindow.setCentralWidget(views)\n"
                     "image = np.random.default_rng(0).integers(0, 255, (480, 640), dtype=np.uint8)\n"
                     "for column in range(2):\n"
                     "    box = views.addViewBox(row=0, col=column, lockAspect=True)\n"
                     "    box.addItem(pg.ImageItem(image))\n"
                     "window.show()\napp.processEvents()\nwindow.repaint()\n")
#: the floor of the panes' toolkit: two 640 x 480 images written as PNG, read back with OpenCV and shown in
#: plain QGraphicsViews (the script's first argument is a folder to write the images in)
_IMAGES_WINDOW = ("import sys\nimport cv2\nimport numpy as np\nfrom PySide6 import QtGui, QtWidgets\n"
                  "app = QtWidgets.QApplication([])\nwindow = QtWidgets.QMainWindow()\n"
                  "split = QtWidgets.QSplitter()\nwindow.setCentralWidget(split)\n"
                  "image = np.random.default_rng(0).integers(0, 255, (480, 640), dtype=np.uint8)\n"
                  "for column in range(2):\n"
                  "    path = f'{sys.argv[1]}/image{column}.png'\n"
                  "    cv2.imwrite(path, image)\n"
                  "    pixels = np.ascontiguousarray(cv2.imread(path, cv2.IMREAD_UNCHANGED))\n"
                  "    shown = QtGui.QImage(pixels.data, 640, 480, 640, QtGui.QImage.Format.Format_Grayscale8).copy()\n"
                  "    view = QtWidgets.QGraphicsView(QtWidgets.QGraphicsScene(split))\n"
                  "    view.scene().addPixmap(QtGui.QPixmap.fromImage(shown))\n"
                  "    split.addWidget(view)\n"
                  "window.show()\napp.processEvents()\nwindow.repaint()\n")


def child_cpu_times(arguments: list[str], repeats: int = 3, env: dict[str, str] | None = None,
                    check: bool = False) -> list[float]:
    """The CPU time (s, user + system) of each of ``repeats`` runs of a child process running ``arguments``;
    with ``check``, a run that fails is a :class:`RuntimeError` carrying the end of its stderr."""
    times = []
    for _ in range(max(1, repeats)):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        result = subprocess.run(arguments, capture_output=True, check=False, env=env, timeout=600)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if check and result.returncode != 0:
            raise RuntimeError(f"{' '.join(arguments)} exited with {result.returncode}: "
                               f"{result.stderr.decode(errors='replace')[-800:]}")
        times.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return times


def child_cpu_s(arguments: list[str], repeats: int = 3, env: dict[str, str] | None = None,
                check: bool = False) -> float:
    """The least CPU time (s) a child process running ``arguments`` took over ``repeats`` runs (what the
    start costs; another process on the machine only adds to it); ``check`` as :func:`child_cpu_times`."""
    return min(child_cpu_times(arguments, repeats, env, check))


def window_environment(folder: Path) -> dict[str, str]:
    """The environment of the window's starts: the bench's, offscreen, with the probe asked for, settings,
    data and bytecode in ``folder``, and none of :data:`NOT_A_USERS` (see the module docstring)."""
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", USVIPS_QUIT_WHEN_READY="1",
               XDG_CONFIG_HOME=str(folder / "config"), XDG_DATA_HOME=str(folder / "data"),
               PYTHONPYCACHEPREFIX=str(folder / "bytecode"))
    for name in NOT_A_USERS:
        env.pop(name, None)
    return env


def floor_environment(window: dict[str, str]) -> dict[str, str]:
    """The floors' environment: the window's, with the brief busy-wait ``usvips`` sets itself."""
    from usvips.cli import BLAS_SPIN_LOG2_CYCLES, BLAS_SPIN_VARIABLE

    return {**window, BLAS_SPIN_VARIABLE: str(BLAS_SPIN_LOG2_CYCLES)}


def window_row(repeats: int, bare: float) -> dict:
    """The window's start to usable on a copy of the sample (see the module docstring)."""
    from usvips.locations import sample_project

    with tempfile.TemporaryDirectory(prefix="usvips-bench-window-") as folder:
        sample = shutil.copytree(sample_project(WINDOW_SAMPLE), Path(folder) / WINDOW_SAMPLE)
        env = window_environment(Path(folder))
        command = [sys.executable, "-m", "usvips", "open", str(sample)]
        child_cpu_s(command, 1, env, check=True)  # makes the project file and the bytecode; not timed
        starts = child_cpu_times(command, repeats, env, check=True)
        cpu = min(starts)
        floor = floor_environment(env)
        qt = child_cpu_s([sys.executable, "-c", _EMPTY_WINDOW], repeats, floor, check=True)
        images = [sys.executable, "-c", _IMAGES_WINDOW, folder]
        child_cpu_s(images, 1, floor, check=True)
        plain = child_cpu_s(images, repeats, floor, check=True)
        child_cpu_s([sys.executable, "-c", _PYQTGRAPH_WINDOW], 1, floor, check=True)
        toolkit = child_cpu_s([sys.executable, "-c", _PYQTGRAPH_WINDOW], repeats, floor, check=True)
    return {"name": "start-up CPU: the window, shown with a sample project's first pair drawn", "n": 1,
            "ours_s": round(cpu, 3), "cpu_s": round(cpu, 3), "baseline": "python -c pass",
            "baseline_s": round(bare, 3), "ratio": round(cpu / bare, 2) if bare > 0 else None,
            "qt_window_cpu_s": round(qt, 3), "images_window_cpu_s": round(plain, 3),
            "pyqtgraph_window_cpu_s": round(toolkit, 3), "starts": len(starts),
            "median_cpu_s": round(float(statistics.median(starts)), 3), "target": None,
            "target_s": WINDOW_TARGET_CPU_S,
            "met": bool(cpu <= WINDOW_TARGET_CPU_S), "sample": WINDOW_SAMPLE,
            "load_1min": round(os.getloadavg()[0], 2)}


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    repeats = max(1, round(3 * scale))
    bare = child_cpu_s([sys.executable, "-c", "pass"], repeats)
    for words in (["--help"], ["project", "--help"]):
        cpu = child_cpu_s([sys.executable, "-m", "usvips", *words], repeats)
        yield {"name": f"start-up CPU: usvips {' '.join(words)}", "n": 1, "ours_s": round(cpu, 3),
               "cpu_s": round(cpu, 3),
               "baseline": "python -c pass", "baseline_s": round(bare, 3),
               "ratio": round(cpu / bare, 2) if bare > 0 else None, "target": None, "target_s": TARGET_CPU_S,
               "met": bool(cpu <= TARGET_CPU_S)}
    yield window_row(max(1, round(WINDOW_STARTS * scale)), bare)
