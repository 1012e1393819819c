"""``usvips project new|info|import|export|set-metadata|set-georeference``: the project database from the
command line."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from usvips.cli.common import add_annotator_option
from usvips.cli.project_campaign import register_campaign_action, run_archive_export
from usvips.cli.project_check import register_check_action
from usvips.cli.project_double_read import register_double_read_action
from usvips.cli.project_history import register_history_action
from usvips.cli.project_media import register_project_actions
from usvips.cli.project_pointing import register_pointing_action
from usvips.cli.project_review import register_review_action
from usvips.cli.project_sync import register_sync_actions
from usvips.core.errors import InputFileError, InvalidParameterError, UsvipsError

if TYPE_CHECKING:
    from usvips.core.deployment import Georeference
    from usvips.store.interface import ProjectStore

# Each handler imports the work it needs (the project store, the contents and exports: numpy, SciPy,
# OpenCV): ``usvips project --help`` and the parser of any action load none of them (a row of
# ``usvips bench --only startup``).


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("project", help="create, inspect, import into and export from a project file")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    new = actions.add_parser("new", help="create a project file (optionally from a sample directory)")
    new.add_argument("out", help="the project file to create (*.usvips)")
    new.add_argument("--from", dest="source", help="a sample project directory with project.json")
    add_annotator_option(new)
    new.set_defaults(handler=run_new)
    info = actions.add_parser("info", help="summarise a project file")
    info.add_argument("project")
    info.add_argument("--full-hash", action="store_true", help="check every media file's whole SHA-256 (slow for "
                      "long videos); by default each file's size and a sampled hash")
    info.set_defaults(handler=run_info)
    accept = actions.add_parser("accept-media", help="take the file now at a recorded media path as the one meant "
                                "(after a changed file was named): its size and hashes are recorded anew")
    accept.add_argument("project")
    accept.add_argument("media", nargs="+", help="the recorded path(s), as project info shows them")
    accept.set_defaults(handler=run_accept_media)
    relocate = actions.add_parser("relocate-media", help="point a recorded media file at its new place (the same "
                                  "file: size and SHA-256 are checked)")
    relocate.add_argument("project")
    relocate.add_argument("media", help="the recorded path, as project info shows it")
    relocate.add_argument("new", help="where the file is now")
    relocate.set_defaults(handler=run_relocate_media)
    imp = actions.add_parser("import", help="import control, observations or a calibration into a project")
    imp.add_argument("project")
    imp.add_argument("--control", help="control CSV")
    imp.add_argument("--obs", help="observations CSV (with --pair and --role)")
    imp.add_argument("--pair", help="the image pair the observations belong to (created if new); a file with a "
                     "pair column of several pairs gives this pair's rows")
    imp.add_argument("--role", default="calibration-water", help="observation role (default calibration-water)")
    imp.add_argument("--calibration", help="calibration JSON (with --active-for PAIR ...)")
    imp.add_argument("--active-for", nargs="+", action="extend", default=[],
                     help="pairs (or videos) the calibration becomes active for; may be repeated")
    add_annotator_option(imp)
    imp.set_defaults(handler=run_import)
    exp = actions.add_parser("export", help="export measured objects: .csv, .vertices.csv, .geojson (WGS 84; needs "
                             "set-georeference), .ply (ASCII) or .binary.ply, or NAME.em.txt for EventMeasure-style "
                             "NAME_Lengths.txt, NAME_3DPoints.txt, tables of their own (NAME_Polygons.txt, "
                             "NAME_Circles.txt) and CheckEM's NAME_Metadata.csv, all or nothing")
    exp.add_argument("project")
    exp.add_argument("out")
    exp.add_argument("--opcode", help="EventMeasure OpCode of objects with no stored deployment (see "
                     "set-metadata); default: the project file's name")
    exp.add_argument("--force", action="store_true", help="replace OUT even when it is a USVIPS project or "
                     "calibration (the old file is kept as OUT.bak); never the project exported")
    exp.add_argument("--format", choices=["globalarchive", "training-set"], help="globalarchive: OUT is a folder "
                     "(made if missing); the campaign's CAMPAIGNID_Metadata.csv, _Count.txt (MaxN) and _Length.txt "
                     "with the EventMeasure-style tables CheckEM reads, all or nothing (needs set-campaign and "
                     "set-metadata); training-set: OUT is a new folder of the accepted snout-fork lengths as "
                     "crops with YOLO-pose labels and the reviewers' corrections of model proposals "
                     "(docs/detection.md)")
    exp.add_argument("--reader", metavar="NAME", help="with --format globalarchive: only the objects this annotator "
                     "made (a double-read survey would otherwise count its fish twice)")
    exp.set_defaults(handler=run_export)
    register_project_actions(actions)  # add-pairs, add-video: usvips/cli/project_media.py
    register_metadata_actions(actions)  # set-metadata, set-georeference: below
    register_check_action(actions)  # check: usvips/cli/project_check.py
    register_sync_actions(actions)  # push, pull: usvips/cli/project_sync.py
    register_history_action(actions)  # history: usvips/cli/project_history.py
    register_campaign_action(actions)  # set-campaign (and export --format globalarchive): cli/project_campaign.py
    register_double_read_action(actions)  # double-read: usvips/cli/project_double_read.py
    register_review_action(actions)  # review: usvips/cli/project_review.py
    register_pointing_action(actions)  # pointing: usvips/cli/project_pointing.py


def run_new(args: argparse.Namespace) -> int:
    from usvips.app.samples import create_from_manifest
    from usvips.store.location import shown
    from usvips.store.opening import create_project

    project = create_from_manifest(args.source, args.out) if args.source else create_project(args.out)
    project.close()
    print(f"created {shown(args.out)}")
    return 0


def run_info(args: argparse.Namespace) -> int:
    from usvips.app.project_contents import objects_text, reviews_text, summarise
    from usvips.core.deployment import DEPLOYMENT_FIELDS
    from usvips.store.location import shown
    from usvips.store.opening import open_project

    with open_project(args.project, read_only=True) as project:
        summary = summarise(project)
        media = project.media_problems(check_hash=args.full_hash)
        located = {stored: project.media_location(stored) for stored, _ in media}

    def count(n: int, noun: str) -> str:
        return f"{n} {noun}" + ("" if n == 1 else "s")

    # a video is stored as a pair too (its calibration and vertices refer to it): counted apart
    print(f"{shown(args.project)}: schema {summary.version}, {count(len(summary.pairs), 'image pair')}, "
          f"{count(len(summary.videos), 'video')}, {count(summary.control_count, 'control point')}, "
          f"{objects_text(summary.object_count, summary.instant_count)}")
    if summary.reviews.total:
        print(f"  reviews: {reviews_text(summary.reviews)}"
              + (" (each instant reviewed on its own)" if summary.instant_count else ""))
    for pair in summary.pairs:
        print(f"  pair {pair.label} ({pair.medium}): {pair.left or '-'} | {pair.right or '-'}"
              + (f"; calibration {pair.calibration_id}" if pair.calibration_id else ""))
    for scope, deployment in summary.deployments.items():
        print(f"  deployment {deployment.opcode}" + (f" (video {scope})" if scope else "") + ": "
              + ", ".join(f"{name} {getattr(deployment, name)}" for name in DEPLOYMENT_FIELDS[1:]
                          if getattr(deployment, name) not in ("", None)))
    georeference = summary.georeference
    if georeference is not None:
        print(f"  georeference: origin {georeference.latitude:.7f}°, {georeference.longitude:.7f}°, depth "
              f"{georeference.depth_m:g} m, +X heading {georeference.heading_deg:g}°")
    for calibration in summary.calibrations:
        phase = {"air": "phase 1, air", "water": "phase 2, water", "joint": "phase 2, water"}.get(
            calibration.phase or "", calibration.phase or "phase unknown")
        print(f"  calibration {calibration.id} {calibration.name!r} ({phase}"
              + (f", sigma0 {calibration.sigma0_px:.3g} px" if calibration.sigma0_px is not None else "")
              + f"): active for {', '.join(calibration.active_for) or 'none'}")
    for video in summary.videos:
        print(f"  video {video.label}: {video.frame_count} frames at {video.fps:.6g} fps, offset "
              f"{video.offset_frames:+d} frames (left frame i ↔ right frame i {video.offset_frames:+d}); {video.medium}"
              + (f"; calibration {video.calibration_id}" if video.calibration_id else "")
              + (f"; seek proxies {video.proxy_bytes / 2**20:.1f} MiB" if video.proxy_bytes else ""))
    for stored, problem in media:  # what is missing or changed, and where it was
        print(f"  media {stored}: {problem}" + (f" (recorded at {located[stored]})" if not Path(stored).is_absolute()
                                                else ""))
    if media:
        print(f"  {len(media)} media file(s) cannot be used until relocated or accepted "
              "(usvips project relocate-media / accept-media)")
    return 0


def run_accept_media(args: argparse.Namespace) -> int:
    from usvips.app.media_acceptance import recorded_shapes, refuse_swapped, refuse_unlike
    from usvips.app.video_project import file_sha256
    from usvips.store.opening import open_project
    from usvips.store.survey import sampled_hash

    with open_project(args.project) as project:
        records = project.media_records()
        recorded = {path: sha for path, _, _, sha in records}
        shapes = recorded_shapes(project)
        hashed = {}
        for stored in args.media:  # every file checked before any is accepted
            where = project.media_location(stored)
            if stored in recorded and where.is_file():
                hashed[stored] = (where.stat().st_size, file_sha256(where), sampled_hash(where))
                refuse_swapped(records, stored, where, hashed[stored][1])
                refuse_unlike(where, shapes.get(stored, ()))
        for stored in args.media:
            project.accept_media(stored, expected_sha256=recorded.get(stored), hashed=hashed.get(stored))
            print(f"accepted {stored} as it is now")
    return 0


def run_relocate_media(args: argparse.Namespace) -> int:
    from usvips.store.opening import open_project

    with open_project(args.project) as project:
        recorded = {path: sha for path, _, _, sha in project.media_records()}
        new = project.relocate_media(args.media, args.new, expected_sha256=recorded.get(args.media))
    print(f"{args.media} is now {new}")
    return 0


def run_import(args: argparse.Namespace) -> int:
    from usvips.app.project_contents import plan_import, store_import
    from usvips.core.errors import UsvipsError
    from usvips.store.location import shown
    from usvips.store.opening import open_project

    if not (args.control or args.obs or args.calibration):
        raise UsvipsError("nothing to import: give --control, --obs or --calibration")
    # every file is read and checked before the project is opened; then all goes in one transaction
    plan = plan_import(args.control, args.obs, args.pair, args.role, args.calibration, tuple(args.active_for))
    with open_project(args.project) as project:
        said = store_import(project, plan)
    print(f"imported into {shown(args.project)}: {'; '.join(said)}")
    return 0


def run_export(args: argparse.Namespace) -> int:
    if args.format == "globalarchive":
        return run_archive_export(args)
    if args.format == "training-set":
        return run_training_set_export(args)
    if args.reader is not None:
        raise UsvipsError("--reader goes with --format globalarchive (the other exports hold every object)")
    from usvips.app.project_contents import media_files
    from usvips.app.project_export import export_project, export_targets
    from usvips.io.atomic import replacing
    from usvips.store.opening import open_project

    if args.opcode is not None:
        from usvips.core import validation

        validation.printable("--opcode", args.opcode)
        if not args.opcode.strip():
            raise InvalidParameterError("--opcode", "must not be empty (leave the option out for the stored "
                                        "deployments' OpCodes)")
    skipped: list[str] = []
    with open_project(args.project, read_only=True) as project, \
            replacing(export_targets(args.out), media_files(project), project=args.project, replace=args.force,
                      parameter="out"):
        count = export_project(project, args.out, args.opcode, skipped=skipped)
    for reason in skipped:
        print(f"skipped {reason}")
    print(f"exported {count} objects to {args.out}")
    return 0


def run_training_set_export(args: argparse.Namespace) -> int:
    from usvips.app.training_set import export_training_set
    from usvips.store.opening import open_project

    if args.reader is not None or args.opcode is not None or args.force:
        raise UsvipsError("--format training-set takes neither --reader, --opcode nor --force (it writes a new "
                          "folder and never replaces one)")
    with open_project(args.project, read_only=True) as project:
        written, corrections, skipped = export_training_set(project, args.out)
    for reason in skipped:
        print(f"skipped {reason}")
    print(f"exported {written} samples (crops with YOLO-pose labels) and {corrections} keypoint corrections to "
          f"{args.out}")
    return 0


# ---------------------------------------------------------------------------- deployment metadata
_METADATA_OPTIONS = {
    "opcode": "the sample id of the deployment (required the first time)",
    "date": "YYYY-MM-DD", "time": "HH:MM or HH:MM:SS (local)",
    "latitude": "decimal degrees, WGS 84, north positive", "longitude": "decimal degrees, east positive",
    "depth_m": "metres below the surface", "site": "", "location": "", "status": "e.g. Fished or No-take",
    "successful_count": "yes or no: usable for counts", "successful_length": "yes or no: usable for lengths",
    "observer": "", "comment": ""}


def register_metadata_actions(actions: argparse._SubParsersAction) -> None:
    meta = actions.add_parser("set-metadata", help="store the deployment metadata (CheckEM's _Metadata.csv) of "
                              "the project or of one video; options not given keep their stored values")
    meta.add_argument("project")
    meta.add_argument("--video", help="the stereo video this deployment is (default: the whole project)")
    for name, text in _METADATA_OPTIONS.items():
        option = "--depth" if name == "depth_m" else "--" + name.replace("_", "-")
        meta.add_argument(option, dest=name, help=text or None)
    meta.add_argument("--clear", action="store_true", help="remove the stored deployment metadata")
    meta.set_defaults(handler=run_set_metadata)
    geo = actions.add_parser("set-georeference", help="store where the object frame lies on the Earth (for "
                             "GeoJSON): its origin and the heading of its +X axis; Z is up")
    geo.add_argument("project")
    geo.add_argument("--latitude", help="origin latitude, decimal degrees WGS 84")
    geo.add_argument("--longitude", help="origin longitude, decimal degrees WGS 84")
    geo.add_argument("--depth", default="0", help="origin depth, metres below the surface (default 0)")
    geo.add_argument("--heading", default="0", help="direction of +X, degrees clockwise from true north (default 0)")
    geo.add_argument("--points", metavar="GEO.csv", help="instead of the origin: control points of the project "
                     "with geographic coordinates (id,latitude,longitude,depth); origin and heading are fitted")
    geo.add_argument("--clear", action="store_true", help="remove the georeference")
    geo.set_defaults(handler=run_set_georeference, parameter_options={
        "origin latitude": "--latitude", "origin longitude": "--longitude", "origin depth": "--depth",
        "geographic points": "--points"})


def run_set_metadata(args: argparse.Namespace) -> int:
    from usvips.core import validation
    from usvips.core.deployment import DEPLOYMENT_FIELDS, Deployment
    from usvips.store.opening import open_project

    given = {name: getattr(args, name) for name in _METADATA_OPTIONS if getattr(args, name) is not None}
    for name, value in given.items():  # no control characters in what CheckEM's tables will hold
        option = "--depth" if name == "depth_m" else "--" + name.replace("_", "-")
        validation.printable(option, value)
    with open_project(args.project) as project:
        stored = project.deployments().get(args.video or "")  # the version read (a later change is refused)
        if args.clear:
            if given:
                raise UsvipsError("--clear removes the deployment metadata; give no other values with it")
            project.set_deployment(None, args.video, expected=stored)
            print(f"cleared the deployment metadata of {args.video or 'the project'}")
            return 0
        values = {} if stored is None else {name: getattr(stored, name) for name in DEPLOYMENT_FIELDS}
        values.update(given)
        if not values.get("opcode"):
            raise UsvipsError("--opcode is needed: no deployment is stored for "
                              + (f"video {args.video!r}" if args.video else "the project"))
        deployment = Deployment(**values)
        project.set_deployment(deployment, args.video, expected=stored)
    print(f"stored deployment {deployment.opcode}" + (f" for video {args.video}" if args.video else ""))
    return 0


def run_set_georeference(args: argparse.Namespace) -> int:
    from usvips.core.deployment import Georeference
    from usvips.store.opening import open_project

    if args.clear:
        given = [o for o, v, default in (("--latitude", args.latitude, None), ("--longitude", args.longitude, None),
                                         ("--depth", args.depth, "0"), ("--heading", args.heading, "0"),
                                         ("--points", args.points, None)) if v != default]
        if given:
            raise UsvipsError(f"--clear removes the georeference; give no {', '.join(given)} with it")
    with open_project(args.project) as project:
        read = project.georeference()  # the version this command read: a colleague's change since is refused
        if args.clear:
            project.set_georeference(None, expected=read)
            print("cleared the georeference")
            return 0
        if args.points is not None:
            if args.latitude is not None or args.longitude is not None:
                raise UsvipsError("give either --points or --latitude/--longitude, not both")
            georeference = _fit_georeference(project, args.points)
        else:
            if args.latitude is None or args.longitude is None:
                raise UsvipsError("set-georeference needs --latitude and --longitude, --points, or --clear")
            georeference = Georeference(args.latitude, args.longitude, args.depth, args.heading)
        project.set_georeference(georeference, expected=read)
    print(f"stored the georeference: origin {georeference.latitude:.7f}°, {georeference.longitude:.7f}°, depth "
          f"{georeference.depth_m:g} m, +X heading {georeference.heading_deg:g}°")
    return 0


#: A fitted frame whose best similarity scale is further from 1 than this is refused: the points'
#: geographic and object-frame coordinates do not describe the same places.
MAX_SCALE_MISMATCH = 0.01


def _fit_georeference(project: ProjectStore, points: str) -> Georeference:
    from usvips.io.georeference import georeference_from_points, read_geographic_points

    geographic = read_geographic_points(points)
    georeference, fit, ids = georeference_from_points(project.control(), geographic)
    if abs(fit.scale - 1) > MAX_SCALE_MISMATCH:
        raise InputFileError(points, f"the points do not match the project's control: a similarity would scale "
                             f"them by {fit.scale:.4f} (their horizontal RMS residual is {fit.rms_horizontal_m:.3f} m)")
    print(f"fitted to {len(ids)} points ({', '.join(ids)[:60]}): horizontal RMS {fit.rms_horizontal_m:.4f} m, "
          f"depth RMS {fit.rms_depth_m:.4f} m, similarity scale {fit.scale:.6f}")
    return georeference
