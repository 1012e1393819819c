"""``usvips measure``: objects from picks in a CSV, with their figures and sigmas, without a window.

Picks CSV: ``object,type,vertex,xl,yl,xr,yr[,attribute]`` — pixels; ``type`` a measurement kind (point,
length, arc, polygon, circle, …; the legacy ``line`` is a length with two vertices, an arc with more);
rows of one object share its id and are ordered by ``vertex``. Every vertex is intersected with the
calibration; the figures' sigmas carry the pointing and the calibration's own uncertainty, including the
correlation a common calibration puts between the vertices of one object (the one figure path,
``usvips.core.measurements.measure_picks``). The work is in :mod:`usvips.app.measure`; this module
parses the arguments, writes the table and prints.

With ``--project P --video LABEL --frame N`` they are measured on the video's left frame N (and the
right frame synchronised with it) and stored as the window stores a video frame's objects.

With ``--project P --pair LABEL`` the objects are measured with the calibration active for that pair and
stored in the project exactly as the window stores them (all of them in one transaction, or none);
``--out`` then is optional. With ``--calibration`` the frame is ``--frame`` at ``--station``.
"""

from __future__ import annotations

import argparse

import numpy as np

from usvips.app.measure import (
    MEASUREMENT_COLUMNS,
    group_picks,
    measure_into_project,
    measure_objects,
    measurement_row,
    pointing_line,
    read_picks,
)
from usvips.cli.common import add_annotator_option, add_pointing_option, csv_text, write_text_atomic
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.io.atomic import replacing
from usvips.io.calibration_file import load_calibration
from usvips.io.tables import refuse_outside_image
from usvips.store.location import shown
from usvips.store.opening import open_project

__all__ = ["group_picks", "read_picks", "register", "run"]

OUT_COLUMNS = MEASUREMENT_COLUMNS


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("measure", help="measure objects from picks: figures with sigmas (CSV), "
                                                   "optionally stored in a project")
    parser.add_argument("--calibration", help="calibration file (JSON); or use --project with --pair")
    parser.add_argument("--picks", required=True, help="picks CSV: object,type,vertex,xl,yl,xr,yr[,attribute]")
    parser.add_argument("--out", help="objects CSV to write (required without --project)")
    parser.add_argument("--project", help="project file to store the objects in (with --pair)")
    parser.add_argument("--pair", help="the project's image pair the picks belong to (its active calibration)")
    parser.add_argument("--video", help="with --project and --frame N: the project's stereo video the picks were "
                                        "made on (instead of --pair)")
    parser.add_argument("--station", help="calibrated station (index or label) for the frame (default 0; "
                                          "with --calibration only)")
    parser.add_argument("--frame", help="with --calibration: the coordinate frame, object (default) or rig; with "
                                        "--video: the left frame number N the picks were made on (the right one is "
                                        "the frame synchronised with it)")
    parser.add_argument("--force", action="store_true", help="replace --out even when it is an input or holds a "
                        "USVIPS calibration or project (the old file is kept as NAME.bak); never the --project")
    add_pointing_option(parser)
    add_annotator_option(parser)
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    if args.project is None and (args.calibration is None or args.out is None):
        raise UsvipsError("measure needs --calibration and --out, or --project with --pair")
    if args.project is None and args.pair is not None:
        raise UsvipsError("--pair goes with --project (the pair's active calibration measures); with "
                          "--calibration, leave it out")
    args.video_frame = None
    if args.video is not None:
        if args.project is None or args.pair is not None or args.frame is None:
            raise UsvipsError("--video goes with --project and --frame N (the left frame), without --pair")
        if not args.frame.isdigit():
            raise InvalidParameterError("--frame", f"with --video: a frame number (0, 1, 2 …), got {args.frame!r}")
        args.video_frame, args.frame = int(args.frame), None
    elif args.frame is not None and args.frame not in ("object", "rig"):
        raise InvalidParameterError("--frame", f"object or rig (a frame number goes with --video), got {args.frame!r}")
    if args.project is not None:
        if args.pair is None and args.video is None:
            raise UsvipsError("--project needs --pair (the image pair whose active calibration measures) or "
                              "--video with --frame N")
        if args.calibration is not None or args.station is not None or args.frame is not None:
            raise UsvipsError("--project measures with the pair's active calibration in the pair's frame: "
                              "leave out --calibration, --station and --frame")
    outputs = [] if args.out is None else [args.out]
    with replacing(outputs, [args.calibration, args.picks], args.project, replace=args.force):
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    calibration = load_calibration(args.calibration) if args.calibration is not None else None
    rows = read_picks(args.picks)
    if calibration is not None:
        pixels = np.array([row["pixels"] for row in rows], dtype=np.float64).reshape(-1, 4)
        refuse_outside_image(args.picks, [f"{row['object']}/{row['vertex']}" for row in rows],
                             [row["line"] for row in rows], pixels[:, :2], pixels[:, 2:],
                             ((calibration.left.width, calibration.left.height),
                              (calibration.right.width, calibration.right.height)))
    objects = group_picks(args.picks, rows)
    if args.project is not None:
        label = args.pair if args.video is None else args.video
        with open_project(args.project) as project:
            measured, ids = measure_into_project(project, label, objects, where=args.picks, frame=args.video_frame,
                                                 pointing_sigma_px=args.pointing_sigma)
        place = f"pair {label}" if args.video is None else f"video {label}, frame {args.video_frame}"
        many = len(ids) != 1  # "stored 1 object …: id 5", not "1 objects … ids 5"
        print(f"stored {len(ids)} object{'s' if many else ''} in {shown(args.project)} ({place}): "
              f"id{'s' if many else ''} {', '.join(map(str, ids))}")
    else:
        station = args.station if args.station is not None else "0"
        station = int(station) if station.isdigit() else station
        measured = measure_objects(calibration, objects, station, args.frame or "object", where=args.picks,
                                   pointing_sigma_px=args.pointing_sigma)
    print(pointing_line(measured[0] if measured else None, args.pointing_sigma)
          + ("" if args.pointing_sigma is not None else " (--pointing-sigma PX to state yours)"))
    if args.out is not None:
        write_text_atomic(args.out, csv_text(OUT_COLUMNS, [measurement_row(m) for m in measured]))
        print(f"measured {len(measured)} objects; wrote {args.out}")
    return 0
