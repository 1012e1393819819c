"""``usvips measure``: objects from picks in a CSV, with their figures and sigmas, without a window.

Picks CSV: ``object,type,vertex,xl,yl,xr,yr[,attribute]`` — pixels; ``type`` a measurement kind (point,
length, arc, polygon, circle, …; the legacy ``line`` is a length with two vertices, an arc with more);
rows of one object share its id and are ordered by ``vertex``. Every vertex is intersected with the
calibration; the figures' sigmas carry the pointing and the calibration's own uncertainty, including the
correlation a common calibration puts between the vertices of one object (the one figure path,
``usvips.core.measurements.measure_picks``).

With ``--project P --pair LABEL`` the objects are measured with the calibration active for that pair and
stored in the project exactly as the window stores them (all of them in one transaction, or none);
``--out`` then is optional. With ``--calibration`` the frame is ``--frame`` at ``--station``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from usvips.app.project_figures import store_measurements
from usvips.cli.common import csv_text, write_text_atomic
from usvips.core.errors import DegenerateGeometryError, InputFileError, UsvipsError
from usvips.core.measurements import Measurement, kind, measure_picks, resolve
from usvips.io import tables
from usvips.io.calibration_file import load_calibration
from usvips.io.export import cell, number
from usvips.store import Project

COLUMNS = ("object", "type", "vertex", "xl", "yl", "xr", "yr")
OUT_COLUMNS = ["object", "type", "attribute", "vertices", "figure", "value", "sigma", "X", "Y", "Z", "ray_rms_mm",
               "range_m", "quality"]


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("measure", help="measure objects from picks: figures with sigmas (CSV), "
                                                   "optionally stored in a project")
    parser.add_argument("--calibration", help="calibration file (JSON); or use --project with --pair")
    parser.add_argument("--picks", required=True, help="picks CSV: object,type,vertex,xl,yl,xr,yr[,attribute]")
    parser.add_argument("--out", help="objects CSV to write (required without --project)")
    parser.add_argument("--project", help="project file to store the objects in (with --pair)")
    parser.add_argument("--pair", help="the project's image pair the picks belong to (its active calibration)")
    parser.add_argument("--station", help="calibrated station (index or label) for the frame (default 0; "
                                          "with --calibration only)")
    parser.add_argument("--frame", choices=["object", "rig"], help="frame (default object; with --calibration "
                                                                   "only)")
    parser.set_defaults(handler=run)


def read_picks(path: str | Path) -> list[dict]:
    """The picks file's rows, read and checked by :func:`usvips.io.tables.read_picks`."""
    return tables.read_picks(path)


def group_picks(path: str | Path, rows: list[dict]) -> list[tuple[str, str, np.ndarray, str]]:
    """(object id, registered kind, pixels (N, 4) xl yl xr yr, attribute) per object, in file order."""
    objects: dict[str, list[dict]] = {}
    for row in rows:
        objects.setdefault(row["object"], []).append(row)
    out = []
    for object_id, vertices in objects.items():
        vertices.sort(key=lambda r: r["vertex"])
        if any(v["type"] != vertices[0]["type"] for v in vertices):
            raise InputFileError(str(path), f"object {object_id!r} mixes types", vertices[0]["line"])
        try:
            name = resolve(vertices[0]["type"], len(vertices))
            kind(name).check_count(len(vertices))
        except UsvipsError as error:
            raise InputFileError(str(path), f"object {object_id!r}: {error}", vertices[0]["line"]) from None
        out.append((object_id, name, np.array([v["pixels"] for v in vertices]), vertices[0]["attribute"]))
    return out


def run(args: argparse.Namespace) -> int:
    if args.project is None and (args.calibration is None or args.out is None):
        raise UsvipsError("measure needs --calibration and --out, or --project with --pair")
    if args.project is not None:
        if args.pair is None:
            raise UsvipsError("--project needs --pair (the image pair whose active calibration measures)")
        if args.calibration is not None or args.station is not None or args.frame is not None:
            raise UsvipsError("--project measures with the pair's active calibration in the pair's frame: "
                              "leave out --calibration, --station and --frame")
    calibration = load_calibration(args.calibration) if args.calibration is not None else None
    objects = group_picks(args.picks, read_picks(args.picks))
    if args.project is not None:
        with Project.open(args.project) as project:
            measured, ids = store_measurements(project, args.pair, objects, where=args.picks)
        print(f"stored {len(ids)} objects in {args.project} (pair {args.pair}): ids {', '.join(map(str, ids))}")
    else:
        station = args.station if args.station is not None else "0"
        station = int(station) if station.isdigit() else station
        frame = args.frame or "object"
        measured = [_measure(args.picks, calibration, object_id, name, pixels, attribute, station, frame)
                    for object_id, name, pixels, attribute in objects]
    if args.out is not None:
        write_text_atomic(args.out, csv_text(OUT_COLUMNS, [_row(m) for m in measured]))
        print(f"measured {len(measured)} objects; wrote {args.out}")
    return 0


def _measure(picks: str, calibration, object_id: str, name: str, pixels: np.ndarray, attribute: str,
             station, frame) -> Measurement:
    try:
        return measure_picks(name, calibration, pixels[:, :2], pixels[:, 2:], station, frame, id=object_id,
                             attribute=attribute)
    except DegenerateGeometryError as error:
        raise DegenerateGeometryError(f"{picks}: object {object_id!r}: {error}") from None


def _row(m: Measurement) -> list[str]:
    centre = m.points.mean(axis=0)
    return [cell(m.id), m.kind, cell(m.attribute), str(len(m.points)), m.main.name, number(m.main.value),
            number(m.main.sigma), *(number(c) for c in centre), number(m.ray_rms_m * 1000), number(m.range_m),
            "; ".join(m.failures)]

