"""``usvips project new|info|import|export``: the project database from the command line."""

from __future__ import annotations

import argparse

from usvips.app.project_contents import plan_import, store_import, summarise
from usvips.app.project_export import export_project
from usvips.app.samples import create_from_manifest
from usvips.cli.video import register_project_actions
from usvips.store import Project


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("project", help="create, inspect, import into and export from a project file")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    new = actions.add_parser("new", help="create a project file (optionally from a sample directory)")
    new.add_argument("out", help="the project file to create (*.usvips)")
    new.add_argument("--from", dest="source", help="a sample project directory with project.json")
    new.set_defaults(handler=run_new)
    info = actions.add_parser("info", help="summarise a project file")
    info.add_argument("project")
    info.set_defaults(handler=run_info)
    imp = actions.add_parser("import", help="import control, observations or a calibration into a project")
    imp.add_argument("project")
    imp.add_argument("--control", help="control CSV")
    imp.add_argument("--obs", help="observations CSV (with --pair and --role)")
    imp.add_argument("--pair", help="the image pair the observations belong to (created if new); a file with a "
                     "pair column of several pairs gives this pair's rows")
    imp.add_argument("--role", default="calibration-water", help="observation role (default calibration-water)")
    imp.add_argument("--calibration", help="calibration JSON (with --active-for PAIR ...)")
    imp.add_argument("--active-for", nargs="+", default=[], help="pairs the calibration becomes active for")
    imp.set_defaults(handler=run_import)
    exp = actions.add_parser("export", help="export measured objects: .csv, .vertices.csv, .geojson, .ply, "
                             "or NAME.em.txt for EventMeasure-style NAME_Lengths.txt, NAME_3DPoints.txt and "
                             "tables of their own (NAME_Polygons.txt, NAME_Circles.txt), all or nothing")
    exp.add_argument("project")
    exp.add_argument("out")
    exp.add_argument("--opcode", help="EventMeasure OpCode (the sample, e.g. the deployment); default: the "
                     "project file's name")
    exp.set_defaults(handler=run_export)
    register_project_actions(actions)  # add-pairs, add-video: handlers in usvips/cli/video.py


def run_new(args: argparse.Namespace) -> int:
    project = create_from_manifest(args.source, args.out) if args.source else Project.create(args.out)
    project.close()
    print(f"created {args.out}")
    return 0


def run_info(args: argparse.Namespace) -> int:
    with Project.open(args.project, read_only=True) as project:
        summary = summarise(project)
    print(f"{args.project}: schema {summary.version}, {summary.pair_count} image pairs, "
          f"{summary.control_count} control points, {summary.object_count} objects")
    for pair in summary.pairs:
        print(f"  pair {pair.label} ({pair.medium}): {pair.left or '-'} | {pair.right or '-'}"
              + (f"; calibration {pair.calibration_id}" if pair.calibration_id else ""))
    for video in summary.videos:
        print(f"  video {video.label}: {video.frame_count} frames at {video.fps:.6g} fps, offset "
              f"{video.offset_frames:+d} frames (left frame i ↔ right frame i {video.offset_frames:+d})"
              + (f"; calibration {video.calibration_id}" if video.calibration_id else ""))
    return 0


def run_import(args: argparse.Namespace) -> int:
    # every file is read and checked before the project is opened; then all goes in one transaction
    plan = plan_import(args.control, args.obs, args.pair, args.role, args.calibration, tuple(args.active_for))
    with Project.open(args.project) as project:
        store_import(project, plan)
    print(f"imported into {args.project}")
    return 0


def run_export(args: argparse.Namespace) -> int:
    skipped: list[str] = []
    with Project.open(args.project, read_only=True) as project:
        count = export_project(project, args.out, args.opcode, skipped=skipped)
    for reason in skipped:
        print(f"skipped {reason}")
    print(f"exported {count} objects to {args.out}")
    return 0
