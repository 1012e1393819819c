"""``usvips bench``: speed measured as ratios against a baseline timed side by side in the same run.

Each area has a module here with ``benchmarks(scale) -> Iterable[dict]``; every row holds ``name``,
``n`` (items processed), ``ours_s`` and ``baseline_s`` (best of repeats, seconds), ``baseline`` (what it
was compared with), ``ratio`` = ours / baseline and ``target`` (the ratio we promise not to exceed, or
null for an absolute target given in ``target_s``), and ``met``. Machines here are shared and noisy:
ratios, not absolute times, are what we track.

An area is any module of this package that defines a top-level ``benchmarks(scale)`` (found without
importing it: adding a module adds its area, no registration needed), plus the window's areas in the GUI
package: ``usvips/gui/qt/bench.py`` is the area ``gui`` and ``usvips/gui/qt/bench_NAME.py`` the area
``window_NAME`` (Qt stays inside the GUI package; it is imported only in the child process that runs the
area). :func:`run` runs every area in a child process of its own (:mod:`usvips.bench.area_process`), so
an area that fails, hangs or crashes names itself by a row holding its ``error`` and every other area
still reports; each row carries its ``area``.
"""

from __future__ import annotations

import ast
import importlib.util
import json
import pkgutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

#: Areas that contribute benchmarks, in the order they run: modules of this package, except ``gui`` and
#: ``window_tracking``, which live in ``usvips.gui.qt.bench`` and ``usvips.gui.qt.bench_tracking`` (Qt stays inside the
#: GUI package; it is imported only when run).
BENCH_MODULES: tuple[str, ...] = ("geometry", "scaling", "calibration", "imaging", "gui", "video", "survey",
                                  "window_tracking", "targets", "board_detection", "server", "startup",
                                  "sigma_check", "pointing_experiment", "figures")
BENCH_PATHS: dict[str, str] = {"gui": "usvips.gui.qt.bench", "window_tracking": "usvips.gui.qt.bench_tracking"}


def best_time(function: Callable[[], object], repeats: int = 3) -> float:
    """The fastest of ``repeats`` runs of ``function`` (seconds)."""
    best = float("inf")
    for _ in range(max(1, repeats)):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def ratio_row(name: str, n: int, ours: Callable[[], object], baseline: Callable[[], object],
              baseline_name: str, target: float | None, repeats: int = 3, **extra: object) -> dict:
    """Time ``ours`` and ``baseline`` alternately and return one result row."""
    ours()  # warm caches and lazy imports before timing
    baseline()
    ours_s = best_time(ours, repeats)
    baseline_s = best_time(baseline, repeats)
    ratio = ours_s / baseline_s if baseline_s > 0 else float("inf")
    row = {"name": name, "n": n, "ours_s": round(ours_s, 6), "baseline": baseline_name,
           "baseline_s": round(baseline_s, 6), "ratio": round(ratio, 4), "target": target,
           "met": None if target is None else bool(ratio <= target)}
    row.update(extra)
    return row


#: the seconds an area may take in its child process before it is stopped and named as failed
AREA_TIMEOUT_S = 1200.0


def _defines_benchmarks(path: Path) -> bool:
    """Whether the Python file ``path`` defines a top-level ``benchmarks`` function (read, not imported)."""
    try:
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    except (OSError, SyntaxError, ValueError):
        return True  # a broken area is still an area: running it names the error
    return any(isinstance(node, ast.FunctionDef) and node.name == "benchmarks" for node in tree.body)


def _package_folder(package: str) -> Path | None:
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations)))


def areas() -> dict[str, str]:
    """Every area's name → its module, in the order they run: :data:`BENCH_MODULES` first, then the areas
    found in this package and the GUI package that are not listed there (alphabetically)."""
    found: dict[str, str] = {}
    here = _package_folder(__name__)
    for module in pkgutil.iter_modules([str(here)] if here else []):
        if not module.ispkg and not module.name.startswith("_") and _defines_benchmarks(here / f"{module.name}.py"):
            found[module.name] = f"{__name__}.{module.name}"
    gui = _package_folder("usvips.gui.qt")
    for module in pkgutil.iter_modules([str(gui)] if gui else []):
        if module.name == "bench" or module.name.startswith("bench_"):
            if _defines_benchmarks(gui / f"{module.name}.py"):
                name = "gui" if module.name == "bench" else "window_" + module.name.removeprefix("bench_")
                found[name] = f"usvips.gui.qt.{module.name}"
    ordered = {name: BENCH_PATHS.get(name, f"{__name__}.{name}") for name in BENCH_MODULES}
    ordered.update({name: found[name] for name in sorted(found) if name not in ordered})
    return ordered


def error_row(area: str, error: str) -> dict:
    """The row of an area that failed: it names the area and its error, and is never met."""
    return {"name": f"area {area} failed", "area": area, "n": 0, "ours_s": None, "baseline": None,
            "baseline_s": None, "ratio": None, "target": None, "met": False, "error": error}


@dataclass
class AreaRun:
    """How one area ran: its rows (an error row last when it failed), its wall and CPU seconds and the
    peak resident memory of its process (MB)."""

    area: str
    rows: list[dict]
    wall_s: float
    cpu_s: float | None
    peak_rss_mb: float | None

    @property
    def error(self) -> str | None:
        return next((row["error"] for row in self.rows if "error" in row), None)

    def summary(self) -> dict:
        return {"area": self.area, "rows": sum("error" not in row for row in self.rows),
                "wall_s": round(self.wall_s, 2), "cpu_s": None if self.cpu_s is None else round(self.cpu_s, 2),
                "peak_rss_mb": None if self.peak_rss_mb is None else round(self.peak_rss_mb, 1),
                "error": self.error}


def run_area(area: str, scale: float = 1.0, timeout_s: float = AREA_TIMEOUT_S) -> AreaRun:
    """Run one area in a child process; its rows come back as they were made, so an area that fails
    part-way keeps the rows it made and ends with an error row naming the failure."""
    module = areas().get(area)
    if module is None:
        return AreaRun(area, [error_row(area, f"there is no area {area!r}")], 0.0, None, None)
    with tempfile.TemporaryDirectory(prefix="usvips-bench-area-") as folder:
        out, err = Path(folder) / "rows.jsonl", Path(folder) / "stderr.txt"
        command = [sys.executable, "-m", "usvips.bench.area_process", area, module, repr(float(scale)), str(out)]
        start = time.perf_counter()
        with open(err, "wb") as stderr:
            child = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=stderr)
            try:
                code = child.wait(timeout=timeout_s)
                failure = None if code == 0 else f"its process exited with {code}"
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()
                failure = f"stopped after {timeout_s:.0f} s"
        wall = time.perf_counter() - start
        rows, done = [], {}
        if out.exists():
            for line in out.read_text(encoding="utf-8").splitlines():
                record = json.loads(line)
                if "area_done" in record:
                    done = record
                else:
                    rows.append(record)
        if failure is not None and not any("error" in row for row in rows):
            tail = err.read_text(encoding="utf-8", errors="replace").strip().splitlines()[-1:] if err.exists() else []
            rows.append(error_row(area, failure + (f": {tail[0][-800:]}" if tail else "")))
    return AreaRun(area, rows, wall, done.get("cpu_s"), done.get("peak_rss_mb"))


def run_areas(only: Iterable[str] | None = None, scale: float = 1.0, timeout_s: float = AREA_TIMEOUT_S,
              done: Callable[[list[AreaRun]], None] | None = None) -> list[AreaRun]:
    """Run the selected areas (all by default, else in the order given), each in its own child process,
    one after the other; ``done(runs so far)`` after each."""
    wanted = list(only) if only else list(areas())
    runs: list[AreaRun] = []
    for area in wanted:
        runs.append(run_area(area, scale, timeout_s))
        if done is not None:
            done(runs)
    return runs


def run(only: Iterable[str] | None = None, scale: float = 1.0) -> list[dict]:
    """The rows of the selected areas (all by default) at ``scale`` × the nominal size; an area that
    failed gives a row naming its error (see :func:`run_areas`)."""
    return [row for area in run_areas(only, scale) for row in area.rows]
