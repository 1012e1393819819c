"""How batch work grows with its input: ``usvips intersect`` at 10³ … 10⁶ points.

Each row times the whole command in this process (read the observations CSV, intersect with the
calibration's covariance propagated to every point, write the points CSV) at one size, against the same
command at a tenth of that size timed in the same run: a linear path shows a ratio near 10 (less at small
sizes, where fixed costs dominate), a quadratic one near 100. The calibration is the bundled ROV sample's
(flat ports, 25 calibrated parameters with their covariance). The command intersects its chunks on one
worker process per core (:mod:`usvips.app.ordered_pool`): ``ours_cpu_s`` counts this process's CPU time
and its workers'.

The memory row runs the command in a process of its own on ten times the largest size (10⁷ points at
scale 1: the largest file repeated with other ids) with the pointing precision alone (the calibration's
share is timed by the rows above), against the largest size run the same way:
``peak_rss_mb`` / ``baseline_peak_rss_mb`` (the processes' peak resident memory) is the promise of flat
memory (≤ 1.5 as the input grows tenfold); ``worker_peak_rss_mb`` the largest worker's; ``ours_s`` and
``cpu_s`` its wall and CPU time (workers included).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from usvips.bench import best_time
from usvips.cli import intersect as intersect_command
from usvips.io.calibration_file import load_calibration
from usvips.locations import sample_project

#: Promise: each tenfold step of the input costs at most this many times the step before (linear,
#: with room for a loaded machine's noise; quadratic growth would show about 100).
TARGET_RATIO = 13.0
#: Promise: 10⁶ points through the command in under 10 s (wall)
MILLION, MILLION_TARGET_S = 1_000_000, 10.0
#: Promise: the peak memory of a run on ten times the points is at most this many times as large
MEMORY_TARGET = 1.5

CALIBRATION = sample_project("rov_flatport") / "calibration.json"


def write_observations(calibration, n: int, path: Path, seed: int = 11) -> int:
    """A stereo observation CSV of ``n`` points 1.5-4 m in front of the rig, seen by both cameras,
    with 0.3 px of noise; returns the number of rows written."""
    rng = np.random.default_rng(seed)
    rig = calibration.rig(0, frame="object")
    width, height = calibration.left.width, calibration.left.height
    count = 3 * n + 50
    pixels = np.column_stack([rng.uniform(20, width - 20, count), rng.uniform(20, height - 20, count)])
    rays = rig.left.rays(pixels)
    points = rays.origins + rng.uniform(1.5, 4.0, count)[:, None] * rays.directions
    left, right = rig.left.project(points), rig.right.project(points)
    # a margin of 3 px (10 sigmas of the noise added) keeps every noisy pixel inside its image
    inside = np.ones(count, dtype=bool)
    for pixels_of in (left.pixels, right.pixels):
        inside &= np.all((pixels_of >= 2.5) & (pixels_of <= np.array([width, height]) - 3.5), axis=1)
    keep = np.flatnonzero(rays.ok & left.ok & right.ok & inside)[:n]
    table = np.column_stack([left.pixels[keep], right.pixels[keep]]) + rng.normal(0, 0.3, (keep.size, 4))
    lines = [f"p{i},{a:.4f},{b:.4f},{c:.4f},{d:.4f}" for i, (a, b, c, d) in enumerate(table.tolist())]
    path.write_text("id,xl,yl,xr,yr\n" + "\n".join(lines) + "\n", encoding="utf-8")
    return int(keep.size)


def sizes(scale: float = 1.0) -> list[int]:
    """10³ … 10⁶ points times ``scale`` (at least 10 points)."""
    return [max(10, int(round(10**exponent * scale))) for exponent in range(3, 7)]


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    calibration = load_calibration(CALIBRATION)
    with tempfile.TemporaryDirectory(prefix="usvips-bench-") as folder:
        timed: list[tuple[int, float, float]] = []
        for n in sizes(scale):
            obs = Path(folder) / f"obs_{n}.csv"
            out = Path(folder) / f"points_{n}.csv"
            count = write_observations(calibration, n, obs)
            args = argparse.Namespace(calibration=str(CALIBRATION), obs=str(obs), out=str(out), station="0",
                                      frame="object", pointing_only=False, skip_failed=True, force=False,
                                      pointing_sigma=None)

            def command(args=args) -> None:
                with contextlib.redirect_stdout(io.StringIO()):
                    intersect_command.run(args)

            if not timed:
                command()  # load the compiled kernels and warm caches once
            repeats = 3 if count <= 10_000 else 1
            cpu_start = _cpu()
            wall = best_time(command, repeats)
            cpu = (_cpu() - cpu_start) / repeats
            timed.append((count, wall, cpu))
        largest = max(sizes(scale))
        yield from _growth_rows(timed)
        yield memory_row(Path(folder) / f"obs_{largest}.csv", timed[-1][0], Path(folder))


def _cpu() -> float:
    """CPU seconds of this process and of its finished worker processes (the command intersects its
    chunks on one worker per core and stops them before it returns)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def _growth_rows(timed: list[tuple[int, float, float]]) -> Iterator[dict]:
    """Each size against a tenth of it; 10⁶ points also against the absolute promise (10 s, issue 37)."""
    for (small, small_s, small_cpu), (large, large_s, large_cpu) in zip(timed, timed[1:], strict=False):
        ratio = large_s / small_s if small_s > 0 else float("inf")
        row = {"name": "usvips intersect (read CSV, intersect with the calibration's covariance, write CSV)",
               "n": large, "ours_s": round(large_s, 6),
               "baseline": f"the same command on {small} points", "baseline_s": round(small_s, 6),
               "ratio": round(ratio, 4), "target": TARGET_RATIO, "met": bool(ratio <= TARGET_RATIO),
               "ours_cpu_s": round(large_cpu, 6), "baseline_cpu_s": round(small_cpu, 6),
               "points_per_s": round(large / large_s) if large_s > 0 else None,
               "load_1min": round(os.getloadavg()[0], 2)}
        if large >= MILLION:
            row.update(target_s=MILLION_TARGET_S, target_s_met=bool(large_s <= MILLION_TARGET_S))
        yield row


def repeated(source: Path, copies: int, path: Path) -> int:
    """``source`` (an observation file whose ids start with ``p``) written ``copies`` times into ``path``,
    each copy's ids prefixed by its number (so every id is new); returns the rows written."""
    header, body = source.read_text(encoding="utf-8").split("\n", 1)
    with open(path, "w", encoding="utf-8") as out:
        out.write(header + "\n")
        for copy in range(copies):
            out.write(("\n" + body).replace("\np", f"\n{copy}p")[1:])
    return copies * body.count("\n")


#: runs the command line given after it, then writes the process's peak resident memory (kB, VmHWM:
#: this process's own, not the parent's it was started from) and the largest of its worker processes'
#: (kB, ru_maxrss) to stderr's last lines
_MEASURED = ("import resource, sys\nfrom usvips.cli import main\ncode = main(sys.argv[1:])\n"
             "peak = [line.split()[1] for line in open('/proc/self/status') if line.startswith('VmHWM:')]\n"
             "print('peak_kb', peak[0] if peak else 0, file=sys.stderr)\n"
             "print('worker_peak_kb', resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr)\n"
             "sys.exit(code)\n")


def child_run(arguments: list[str]) -> tuple[float, float, float, float]:
    """(wall s, CPU s, peak resident MB, the largest worker's peak resident MB) of ``usvips ARGUMENTS`` run
    in a process of its own (the CPU time of its workers included)."""
    start = time.perf_counter()
    child = subprocess.Popen([sys.executable, "-c", _MEASURED, *arguments], stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE)
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    child.returncode = os.waitstatus_to_exitcode(status)
    errors = child.stderr.read().decode(errors="replace")
    child.stderr.close()
    if child.returncode != 0:
        raise RuntimeError(f"usvips {' '.join(arguments[:1])} exited with {child.returncode}: {errors[-500:]}")
    peaks = [next((line.split()[1] for line in reversed(errors.splitlines()) if line.startswith(f"{name} ")), "0")
             for name in ("peak_kb", "worker_peak_kb")]
    return wall, usage.ru_utime + usage.ru_stime, int(peaks[0]) / 1024, int(peaks[1]) / 1024


def memory_row(largest: Path, count: int, folder: Path) -> dict:
    """The memory row (see the module docstring) on ten copies of ``largest`` (``count`` rows)."""
    big = folder / "obs_ten_times.csv"
    rows = repeated(largest, 10, big)

    def run(obs: Path) -> tuple[float, float, float, float]:
        return child_run(["intersect", "--calibration", str(CALIBRATION), "--obs",
                          str(obs), "--out", str(folder / "points_child.csv"), "--pointing-only", "--skip-failed",
                          "--force"])

    base_wall, base_cpu, base_rss, base_worker_rss = run(largest)
    wall, cpu, rss, worker_rss = run(big)
    big.unlink()
    ratio = rss / base_rss if base_rss > 0 else float("inf")
    return {"name": f"usvips intersect on {rows:,} points (pointing precision only), its own process: peak memory",
            "n": rows, "ours_s": round(wall, 3), "cpu_s": round(cpu, 3), "peak_rss_mb": round(rss, 1),
            "baseline": f"the same on {count:,} points", "baseline_s": round(base_wall, 3),
            "baseline_cpu_s": round(base_cpu, 3), "baseline_peak_rss_mb": round(base_rss, 1),
            "worker_peak_rss_mb": round(worker_rss, 1), "baseline_worker_peak_rss_mb": round(base_worker_rss, 1),
            "ratio": round(ratio, 3), "target": MEMORY_TARGET, "met": bool(ratio <= MEMORY_TARGET),
            "load_1min": round(os.getloadavg()[0], 2)}
