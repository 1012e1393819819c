"""``usvips batch``: run one task over many pairs or projects on every core (usvips/app/batch.py).

``usvips batch intersect --calibration CAL --out-dir DIR OBS...`` re-intersects each observations file
with the calibration (DIR/<name>.points.csv); ``usvips batch export --out-dir DIR --format csv
PROJECT...`` recomputes each project's figures and exports them (DIR/<name>.<format>); ``usvips batch
detect --model M PROJECT...`` stores a detection model's proposals in every pair and video of each project
(app/detection_batch.py). One progress line
per finished task; a failing one prints one line and the others go on. ``--scheduler ADDRESS`` runs the
same tasks on a Dask distributed cluster (``local:N``: N local worker processes; app/batch_cluster.py).
Exit status: 0 when every task succeeded, 2 when any failed, 130 when interrupted (Ctrl-C: running tasks
finish, the rest are cancelled).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from usvips.app import batch
from usvips.core.errors import InvalidParameterError
from usvips.io.atomic import guard_output
from usvips.store.location import database_name, is_server_location, parse_server_location, shown

#: the most worker processes --jobs starts (each holds its own copy of the libraries)
MAX_JOBS = 256
#: export formats and the suffix of the file each writes
EXPORT_SUFFIXES = {"csv": ".csv", "vertices": ".vertices.csv", "geojson": ".geojson", "ply": ".ply",
                   "eventmeasure": ".em.txt", "globalarchive": ""}  # globalarchive: a folder of tables


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("batch", help="run a task over many pairs or projects on every core")
    tasks = parser.add_subparsers(dest="task", metavar="TASK", required=True)
    intersect = tasks.add_parser("intersect", help="re-intersect observation files with a calibration")
    intersect.add_argument("observations", nargs="+", help="observations CSV files (id,xl,yl,xr,yr)")
    intersect.add_argument("--calibration", required=True, help="calibration file (JSON)")
    intersect.add_argument("--station", default=None, help="calibrated station (index or pair label; default: each "
                           "row at the station its pair column names, without one the first)")
    intersect.add_argument("--frame", choices=["object", "rig"], default="object")
    export = tasks.add_parser("export", help="recompute figures and export the objects of projects")
    export.add_argument("projects", nargs="+", help="project files (*.usvips) or surveys (postgresql://…)")
    export.add_argument("--format", choices=sorted(EXPORT_SUFFIXES), default="csv")
    detect = tasks.add_parser("detect", help="propose fish with a detection model in every pair and video of "
                                             "projects (stored as unreviewed objects)")
    detect.add_argument("projects", nargs="+", help="project files (*.usvips) or surveys (postgresql://…)")
    detect.add_argument("--model", metavar="DESCRIPTION", help="the model's description file (default: each "
                        "project's default model, else the model shipped with USVIPS)")
    detect.add_argument("--every", type=int, default=1, metavar="K", help="every K-th left frame of a video")
    for sub in (intersect, export, detect):
        if sub is not detect:
            sub.add_argument("--out-dir", required=True, help="folder for the outputs (created if missing)")
        sub.add_argument("--jobs", type=int, default=None,
                         help=f"worker processes (default: every core, {batch.default_jobs()} here)")
        sub.add_argument("--scheduler", metavar="ADDRESS", help="run on a Dask distributed cluster instead: its "
                         "scheduler's address (tcp://HOST:PORT), or local:N for N local worker processes")
        sub.set_defaults(handler=run)


def _detect_tasks(args: argparse.Namespace) -> list[batch.Task]:
    from usvips.app.detection_batch import detect_project_task
    from usvips.cli.detect import load

    if args.every < 1:
        raise InvalidParameterError("--every", f"must be a whole number >= 1, got {args.every}")
    model = str(args.model) if args.model is not None else None
    if model is not None:
        load(model)  # a bad model: one line, before any task starts
    output_names(args.projects)  # the same project twice is refused
    for given in args.projects:
        if is_server_location(given):
            parse_server_location(given)
    return [batch.Task(shown(given), detect_project_task, {"project": given, "model": model, "every": args.every})
            for given in args.projects]


def _tasks(args: argparse.Namespace, out_dir: Path) -> list[batch.Task]:
    inputs = args.observations if args.task == "intersect" else args.projects
    suffix = ".points.csv" if args.task == "intersect" else EXPORT_SUFFIXES[args.format]
    tasks = []
    for given, name in zip(inputs, output_names(inputs), strict=True):
        if is_server_location(given):
            parse_server_location(given)  # an address that cannot be read: one line, before anything runs
        out = str(out_dir / f"{name}{suffix}")
        if Path(out).exists():  # an output never replaces an input, a project or a calibration
            guard_output(out, [*inputs, getattr(args, "calibration", None)], parameter="out_dir",
                         replaceable=False)
        if args.task == "intersect":
            tasks.append(batch.Task(given, batch.intersect_task, {
                "observations": given, "calibration": args.calibration, "out": out, "station": args.station,
                "frame": args.frame}))
        elif args.format == "globalarchive":
            tasks.append(batch.Task(shown(given), batch.export_archive_task, {"project": given, "out": out}))
        else:
            tasks.append(batch.Task(shown(given), batch.export_project_task, {"project": given, "out": out}))
    return tasks


def output_names(inputs: list[str]) -> list[str]:
    """A distinct output name per input: its file's stem (a server survey: its database), or where two
    stems meet (``a/project.usvips``, ``b/project.usvips``: the samples' own layout) the folders above it
    as far as needed (``a_project``, ``b_project``). The same input given twice is refused."""
    paths = [None if is_server_location(given) else Path(given).resolve() for given in inputs]
    seen: dict[object, str] = {}
    for given, path in zip(inputs, paths, strict=True):
        key = path if path is not None else given
        if key in seen:
            raise InvalidParameterError("inputs", f"{given} is given twice (as {seen[key]} too)")
        seen[key] = given
    depth = [0] * len(inputs)

    def name(k: int) -> str:
        if paths[k] is None:
            return database_name(inputs[k])
        parts = [*paths[k].parent.parts[len(paths[k].parent.parts) - depth[k]:], paths[k].stem]
        return "_".join(part for part in parts if part not in ("", "/"))

    while True:
        names = [name(k) for k in range(len(inputs))]
        clashing = [k for k in range(len(inputs)) if names.count(names[k]) > 1]
        if not clashing:
            return names
        deeper = [k for k in clashing if paths[k] is not None and depth[k] < len(paths[k].parent.parts)]
        if not deeper:
            first, second = (inputs[k] for k in clashing[:2])
            raise InvalidParameterError("inputs", f"{first} and {second} would both write {names[clashing[0]]}; "
                                                  "rename one or run them separately")
        for k in deeper:
            depth[k] += 1


def _line(outcome: batch.Outcome, finished: int, total: int) -> str:
    head = f"[{finished}/{total}]"
    if outcome.status == "ok":
        summary = outcome.summary or {}
        if "proposals" in summary:
            counts = (f"{summary['proposals']} proposals stored, {summary['duplicates']} duplicates not stored, "
                      f"{summary['looked_at']} pairs or videos")
            if summary.get("instants"):
                counts += f", {summary['instants']} joined as instants of a fish seen before"
            if summary.get("skipped"):
                counts += f", {len(summary['skipped'])} skipped"
        elif "files" in summary:
            counts = f"{summary['files']} tables" + (
                f", {len(summary['skipped'])} objects skipped" if summary.get("skipped") else "")
        elif "points" in summary:
            counts = f"{summary['points']} points" + (
                f", {summary['failed']} not intersected" if summary["failed"] else "") + (
                f", {summary['misfits']} whose rays miss beyond the pointing sigma" if summary.get("misfits") else "")
        else:
            counts = f"{summary.get('objects', 0)} objects" + (
                f", {len(summary['skipped'])} skipped" if summary.get("skipped") else "")
        return f"{head} ok {outcome.task.label} -> {summary.get('out')} ({counts})"
    if outcome.status == "cancelled":
        return f"{head} cancelled {outcome.task.label}"
    message = outcome.message  # usually names the input itself
    return f"{head} FAILED " + (message if outcome.task.label in message else f"{outcome.task.label}: {message}")


def run(args: argparse.Namespace) -> int:
    if args.jobs is not None and not 1 <= args.jobs <= MAX_JOBS:
        raise InvalidParameterError("--jobs", f"must be from 1 to {MAX_JOBS} worker processes, got {args.jobs}")
    if args.scheduler is not None:
        from usvips.app.batch_cluster import local_workers

        if args.jobs is not None:
            raise InvalidParameterError("--jobs", "the cluster's workers run the tasks with --scheduler; give one "
                                                  "of --jobs and --scheduler")
        local_workers(args.scheduler)
    if args.task == "detect":
        out_dir, tasks, made = None, _detect_tasks(args), False
    else:
        out_dir = Path(args.out_dir)
        if out_dir.exists() and not out_dir.is_dir():
            raise InvalidParameterError("--out-dir", f"{out_dir} is a file, not a folder")
        tasks = _tasks(args, out_dir)
        made = not out_dir.exists()
        out_dir.mkdir(parents=True, exist_ok=True)

    def progress(outcome: batch.Outcome, finished: int, total: int) -> None:
        print(_line(outcome, finished, total), flush=True)

    try:
        if args.scheduler is not None:
            from usvips.app.batch_cluster import run_on_cluster

            outcomes = run_on_cluster(tasks, args.scheduler, progress)
        else:
            outcomes = batch.run(tasks, args.jobs, progress)
    finally:
        if made and out_dir.is_dir() and not any(out_dir.iterdir()):  # nothing written: no folder left
            out_dir.rmdir()
    done = sum(o.ok for o in outcomes)
    failed = [o for o in outcomes if o.status == "failed"]
    cancelled = sum(o.status == "cancelled" for o in outcomes)
    first = f" (the first: {_line(failed[0], 1, 1).split(' FAILED ', 1)[1]})" if failed else ""
    print(f"batch {args.task}: {done} of {len(outcomes)} succeeded"
          + (f", {len(failed)} failed{first}" if failed else "")
          + (f", {cancelled} cancelled (interrupted)" if cancelled else ""),
          file=sys.stdout if not (failed or cancelled) else sys.stderr, flush=True)
    if cancelled:
        return 130
    return 2 if failed else 0
