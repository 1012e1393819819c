"""``usvips bench``: speed measured as ratios against a baseline timed side by side in the same run.

Each area has a module here with ``benchmarks(scale) -> Iterable[dict]``; every row holds ``name``,
``n`` (items processed), ``ours_s`` and ``baseline_s`` (best of repeats, seconds), ``baseline`` (what it
was compared with), ``ratio`` = ours / baseline and ``target`` (the ratio we promise not to exceed, or
null for an absolute target given in ``target_s``), and ``met``. Machines here are shared and noisy:
ratios, not absolute times, are what we track.
"""

from __future__ import annotations

import importlib
import time
from collections.abc import Callable, Iterable

#: Areas that contribute benchmarks, in the order they run: modules of this package, except ``gui`` and
#: ``window_tracking``, which live in ``usvips.gui.bench`` and ``usvips.gui.bench_tracking`` (Qt stays inside the
#: GUI package; it is imported only when run).
BENCH_MODULES: tuple[str, ...] = ("geometry", "scaling", "calibration", "imaging", "gui", "video", "survey",
                                  "window_tracking", "targets", "board_detection", "server", "startup")
BENCH_PATHS: dict[str, str] = {"gui": "usvips.gui.bench", "window_tracking": "usvips.gui.bench_tracking"}


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


def run(only: Iterable[str] | None = None, scale: float = 1.0) -> list[dict]:
    """Run the benchmarks of the selected modules (all by default) at ``scale`` × the nominal size."""
    wanted = set(only) if only else None
    rows: list[dict] = []
    for name in BENCH_MODULES:
        if wanted is not None and name not in wanted:
            continue
        module = importlib.import_module(BENCH_PATHS.get(name, f"usvips.bench.{name}"))
        rows.extend(module.benchmarks(scale))
    return rows
