"""``usvips project new|info|import|export``: the project database from the command line."""

from __future__ import annotations

import argparse
from pathlib import Path

from usvips.app.project_export import export_project
from usvips.app.samples import create_from_manifest
from usvips.cli.video import register_project_actions
from usvips.core.errors import InputFileError, UsvipsError
from usvips.io.calibration_file import calibration_to_dict, load_calibration
from usvips.io.tables import read_control, read_observations
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
        pairs = project.pairs()
        print(f"{args.project}: schema {project.version}, {len(pairs)} image pairs, "
              f"{len(project.control())} control points, {len(project.objects())} objects")
        videos = project.videos()
        for pair in pairs:
            if pair["label"] in {v["label"] for v in videos}:
                continue  # a video's own pair: listed with the video below
            active = project.active_calibration(pair["label"])
            print(f"  pair {pair['label']} ({pair['medium']}): {pair['left'] or '-'} | {pair['right'] or '-'}"
                  + (f"; calibration {active}" if active else ""))
        for video in videos:
            print(f"  video {video['label']}: {video['frame_count']} frames at {video['fps']:.6g} fps, offset "
                  f"{video['offset_frames']:+d} frames (left frame i ↔ right frame i {video['offset_frames']:+d})"
                  + (f"; calibration {project.active_calibration(video['label'])}"
                     if project.active_calibration(video["label"]) else ""))
    return 0


def run_import(args: argparse.Namespace) -> int:
    if not (args.control or args.obs or args.calibration):
        raise UsvipsError("nothing to import: give --control, --obs or --calibration")
    if args.obs and not args.pair:
        raise UsvipsError("--obs needs --pair (the image pair the observations belong to)")
    # every file is read and checked before the project is opened; then all goes in one transaction
    control = read_control(args.control) if args.control else None
    observations = read_observations(args.obs) if args.obs else None
    if observations is not None and len(observations.pair_labels) > 1:
        if args.pair not in observations.pair_labels:
            raise InputFileError(args.obs, f"holds observations of {len(observations.pair_labels)} pairs "
                                 f"({', '.join(observations.pair_labels)[:80]}); --pair must name one of them")
        observations = observations.pair(args.pair)
    calibration = calibration_to_dict(load_calibration(args.calibration)) if args.calibration else None
    with Project.open(args.project) as project, project.transaction():
        if control is not None:
            project.set_control(control)
        if observations is not None:
            if args.pair not in {p["label"] for p in project.pairs()}:
                project.add_pair(args.pair)
            project.add_control_observations(observations, args.role, args.pair)
        if calibration is not None:
            project.add_calibration(Path(args.calibration).stem, calibration, tuple(args.active_for))
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
