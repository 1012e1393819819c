"""``usvips project new|info|import|export``: the project database from the command line."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from usvips.core.errors import UsvipsError
from usvips.core.intersection import intersect
from usvips.core.measure import MeasuredObject
from usvips.io.calibration_file import calibration_from_dict, calibration_to_dict, load_calibration
from usvips.io.export import export
from usvips.io.tables import read_control, read_observations
from usvips.samples import create_from_manifest
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
    imp.add_argument("--pair", help="the image pair the observations belong to (created if new)")
    imp.add_argument("--role", default="calibration-water", help="observation role (default calibration-water)")
    imp.add_argument("--calibration", help="calibration JSON (with --active-for PAIR ...)")
    imp.add_argument("--active-for", nargs="+", default=[], help="pairs the calibration becomes active for")
    imp.set_defaults(handler=run_import)
    exp = actions.add_parser("export", help="export measured objects: .csv, .vertices.csv, .geojson, .ply, "
                             "or NAME.em.txt for EventMeasure-style NAME_Lengths.txt and NAME_3DPoints.txt")
    exp.add_argument("project")
    exp.add_argument("out")
    exp.add_argument("--opcode", help="EventMeasure OpCode (the sample, e.g. the deployment); default: the "
                     "project file's name")
    exp.set_defaults(handler=run_export)


def run_new(args: argparse.Namespace) -> int:
    project = create_from_manifest(args.source, args.out) if args.source else Project.create(args.out)
    project.close()
    print(f"created {args.out}")
    return 0


def run_info(args: argparse.Namespace) -> int:
    with Project.open(args.project) as project:
        pairs = project.pairs()
        print(f"{args.project}: schema {project.version}, {len(pairs)} image pairs, "
              f"{len(project.control())} control points, {len(project.objects())} objects")
        for pair in pairs:
            active = project.active_calibration(pair["label"])
            print(f"  pair {pair['label']} ({pair['medium']}): {pair['left'] or '-'} | {pair['right'] or '-'}"
                  + (f"; calibration {active}" if active else ""))
    return 0


def run_import(args: argparse.Namespace) -> int:
    if not (args.control or args.obs or args.calibration):
        raise UsvipsError("nothing to import: give --control, --obs or --calibration")
    with Project.open(args.project) as project:
        if args.control:
            project.set_control(read_control(args.control))
        if args.obs:
            if not args.pair:
                raise UsvipsError("--obs needs --pair (the image pair the observations belong to)")
            if args.pair not in {p["label"] for p in project.pairs()}:
                project.add_pair(args.pair)
            project.add_control_observations(read_observations(args.obs), args.role, args.pair)
        if args.calibration:
            path = Path(args.calibration)
            project.add_calibration(path.stem, calibration_to_dict(load_calibration(path)), tuple(args.active_for))
    print(f"imported into {args.project}")
    return 0


def _ray_geometry(project: Project, stored, cache: dict) -> tuple[float, np.ndarray] | None:
    """The ray-intersection RMS (m) of an object's vertices and the left camera's centre (m), from the
    calibration and pair it was measured with; None when that is not known."""
    keys = {(v.calibration_id, v.pair) for v in stored.vertices}
    if len(keys) != 1 or None in next(iter(keys)):
        return None
    calibration_id, label = next(iter(keys))
    if calibration_id not in cache:
        try:
            cache[calibration_id] = calibration_from_dict(project.calibration(calibration_id))
        except UsvipsError:
            cache[calibration_id] = None
    calibration = cache[calibration_id]
    if calibration is None:
        return None
    station, frame = (label, "object") if label in calibration.stations else (0, "rig")
    rig = calibration.rig(station, frame)
    left = np.array([[v.xl, v.yl] for v in stored.vertices])
    right = np.array([[v.xr, v.yr] for v in stored.vertices])
    result = intersect(rig.cameras, [left, right], calibration.sigma0_px)
    if not result.ok.all():
        return None
    return float(np.sqrt(np.mean(result.residuals_m ** 2))), rig.left.exterior.position


def run_export(args: argparse.Namespace) -> int:
    with Project.open(args.project) as project:
        objects, rms, centres, images, cache = [], {}, {}, {}, {}
        pairs = {p["label"]: p for p in project.pairs()}
        for stored in project.objects():
            usable = [v for v in stored.vertices if v.xyz is not None and v.covariance is not None]
            if len(usable) != len(stored.vertices):
                continue
            key = str(stored.id)
            objects.append(MeasuredObject(key, stored.kind, np.array([v.xyz for v in usable]),
                                          np.array([v.covariance for v in usable]), stored.attribute, stored.notes))
            geometry = _ray_geometry(project, stored, cache)
            if geometry is not None:
                rms[key], centres[key] = geometry
            pair = pairs.get(stored.vertices[0].pair) if stored.vertices else None
            if pair is not None:
                frame = "" if pair["frame"] is None else str(pair["frame"])
                images[key] = (Path(pair["left"] or "").name, frame, Path(pair["right"] or "").name, frame)
        opcode = args.opcode if args.opcode is not None else Path(args.project).stem
    export(objects, args.out, opcode=opcode, rms_m=rms, camera_centre={o.id: centres.get(o.id, (0.0, 0.0, 0.0))
                                                                      for o in objects}, images=images)
    print(f"exported {len(objects)} objects to {args.out}")
    return 0
