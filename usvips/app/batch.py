"""Many projects or pairs at once: tasks as plain functions of paths, run on every core.

A **task** is a module-level function of file paths (and plain options) that reads its inputs, writes its
output atomically (all of it or nothing) and returns a small summary dict; it raises a
:class:`~usvips.core.errors.UsvipsError` (or an ``OSError``) naming the file and what is wrong. Tasks
hold no open handles and share nothing, so any executor can run them: :func:`run` uses a
``concurrent.futures`` process pool; a distributed engine runs the same functions, e.g. with Dask::

    import dask
    results = dask.compute(*[dask.delayed(export_project_task)(p, f"out/{p.stem}.csv") for p in projects])

The tasks:

* :func:`intersect_task` — re-intersect a pair's conjugate pixels (observations CSV) with a (new)
  calibration: points CSV ``id, X, Y, Z, sX, sY, sZ`` in metres, as ``usvips intersect`` writes it;
* :func:`export_project_task` — recompute every object's figures from its picks with the calibration it
  was measured with (the one function the window and ``usvips project export`` use) and export them
  (format by the output's suffix: .csv, .vertices.csv, .geojson, .ply, .em.txt).

:func:`run` reports each finished task as an :class:`Outcome` (one line each), keeps going past a
failing one, and on Ctrl-C stops launching new tasks: those running finish (their outputs are whole),
the rest are reported as cancelled.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path

from usvips.app.intersect_file import IntersectOptions, intersect_file
from usvips.app.ordered_pool import forking_safely, reset_worker_signals
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.pointing import HAND_CLICK_SIGMA_PX
from usvips.io.calibration_file import load_calibration
from usvips.io.file_errors import not_a_file


# ------------------------------------------------------------------------------------------------ tasks
def intersect_task(observations: str, calibration: str, out: str, station: str | None = None,
                   frame: str = "object", pointing_sigma_px: float | None = None) -> dict:
    """Intersect the conjugate pixels of ``observations`` (CSV id,xl,yl,xr,yr[,pair]) with ``calibration``
    (JSON) and write the points CSV ``out`` as ``usvips intersect`` does (:func:`usvips.app.intersect_file.
    intersect_file`, in this process: the batch runs its tasks on the cores): at ``station`` (index or pair
    label; None: each row at the station its pair column names) in ``frame`` (object | rig), sigmas with
    the picks' pointing sigma ``pointing_sigma_px`` (px; None: the hand-click default) and the
    calibration's own uncertainty. Points that do not intersect are left out and counted; written points
    whose rays miss more than the pointing sigma explains are counted. Returns {"points": written,
    "failed": count, "misfits": count, "out": out}."""
    at: int | str | None = None if station is None else int(station) if station.isdigit() else station
    pointing = HAND_CLICK_SIGMA_PX if pointing_sigma_px is None else pointing_sigma_px
    summary = intersect_file(load_calibration(calibration), observations, out,
                             IntersectOptions(station=at, frame=frame, pointing_sigma_px=pointing, skip_failed=True,
                                              workers=1))
    return {"points": summary.written, "failed": len(summary.skipped), "misfits": summary.misfits, "out": str(out)}


def export_project_task(project: str, out: str, opcode: str | None = None) -> dict:
    """Recompute the figures of every object of ``project`` (a .usvips file, opened read-only) and export
    them to ``out``. Returns {"objects": written, "skipped": [why, ...], "out": out}."""
    from usvips.app.project_export import export_project
    from usvips.store.location import is_server_location
    from usvips.store.opening import open_project

    skipped: list[str] = []
    if not is_server_location(project) and not Path(project).is_file():
        raise not_a_file(project, "project file")
    with open_project(project, read_only=True) as opened:
        count = export_project(opened, out, opcode, skipped=skipped)
    return {"objects": count, "skipped": skipped, "out": str(out)}


def export_archive_task(project: str, out: str) -> dict:
    """The GlobalArchive tables of ``project`` (opened read-only) in the folder ``out`` (made, all or
    nothing: :func:`usvips.app.archive_export.export_archive_folder`; existing tables are never replaced).
    Returns {"files": written, "skipped": [why, ...], "out": out}."""
    from usvips.app.archive_export import export_archive_folder
    from usvips.store.location import is_server_location
    from usvips.store.opening import open_project

    skipped: list[str] = []
    local = None if is_server_location(project) else project
    if local is not None and not Path(project).is_file():
        raise not_a_file(project, "project file")
    with open_project(project, read_only=True) as opened:
        written = export_archive_folder(opened, out, local, skipped=skipped)
    return {"files": len(written), "skipped": skipped, "out": str(out)}


# ------------------------------------------------------------------------------------------------ running
@dataclass(frozen=True)
class Task:
    """One unit of work: ``function(**arguments)``, named ``label`` in progress lines (e.g. its input)."""

    label: str
    function: Callable[..., dict]
    arguments: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Outcome:
    """What became of a task: ``status`` ok | failed | cancelled, its summary or the one-line reason."""

    task: Task
    status: str
    summary: dict | None = None
    message: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def _worker_start() -> None:
    """In each worker: Ctrl-C is the parent's to handle (a running task finishes its output), and each
    process keeps to one BLAS thread (the pool already uses every core)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    reset_worker_signals()
    try:
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)
    except ImportError:  # pragma: no cover - a declared dependency
        pass


def _execute(function: Callable[..., dict], arguments: dict) -> tuple[str, dict | None, str]:
    """Run one task in a worker; a failure comes back as one line, never as a traceback."""
    try:
        return "ok", function(**arguments), ""
    except UsvipsError as error:
        return "failed", None, str(error)
    except OSError as error:
        where = f"{error.filename}: " if error.filename else ""
        return "failed", None, f"{where}{error.strerror or error}"
    except MemoryError:
        return "failed", None, "not enough memory for this input"
    except Exception as error:  # a bug: one line saying so, the other tasks go on
        return "failed", None, f"internal error ({type(error).__name__}: {error})"


def default_jobs() -> int:
    """Worker processes by default: every core this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def run(tasks: Iterable[Task], jobs: int | None = None,
        progress: Callable[[Outcome, int, int], None] | None = None) -> list[Outcome]:
    """Run ``tasks`` on ``jobs`` worker processes (default :func:`default_jobs`), calling
    ``progress(outcome, finished, total)`` as each finishes; returns the outcomes in the tasks' order.

    A failing task does not stop the others. On Ctrl-C (KeyboardInterrupt in this process) no further
    task starts; the running ones finish and are reported; the rest come back ``cancelled`` (so a caller
    knows it was interrupted when any outcome is cancelled)."""
    tasks = list(tasks)
    jobs = default_jobs() if jobs is None else jobs
    if jobs < 1:
        raise InvalidParameterError("jobs", f"must be at least 1, got {jobs}", label="parallel jobs")
    outcomes: dict[int, Outcome] = {}
    if not tasks:
        return []

    def finish(index: int, outcome: Outcome) -> None:
        outcomes[index] = outcome
        if progress is not None:
            progress(outcome, len(outcomes), len(tasks))

    executor = ProcessPoolExecutor(max_workers=min(jobs, len(tasks)), initializer=_worker_start)
    pending: dict[Future, int] = {}
    try:
        with forking_safely():  # (the first submit forks every worker)
            pending = {executor.submit(_execute, task.function, task.arguments): i for i, task in enumerate(tasks)}
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                index = pending.pop(future)
                status, summary, message = future.result()
                finish(index, Outcome(tasks[index], status, summary, message))
    except KeyboardInterrupt:
        for future, index in list(pending.items()):
            if future.cancel():
                del pending[future]
                finish(index, Outcome(tasks[index], "cancelled", message="interrupted before it started"))
        for future, index in pending.items():  # running: the workers ignore Ctrl-C and finish them
            status, summary, message = future.result()
            finish(index, Outcome(tasks[index], status, summary, message))
    finally:
        executor.shutdown(wait=True, cancel_futures=True)
    return [outcomes[i] for i in range(len(tasks))]
