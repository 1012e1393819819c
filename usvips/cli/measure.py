"""``usvips measure``: objects from picks in a CSV, with their figures and sigmas, without a window.

Picks CSV: ``object,type,vertex,xl,yl,xr,yr[,attribute]`` — pixels; ``type`` point, line or polygon;
rows of one object share its id and are ordered by ``vertex``. Every vertex is intersected with the
calibration; the figures' sigmas carry the pointing and the calibration's own uncertainty, including
the correlation a common calibration puts between the vertices of one object.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from usvips.cli.common import csv_text, write_text_atomic
from usvips.core.calibration.uncertainty import joint_covariance
from usvips.core.errors import DegenerateGeometryError, InputFileError, InvalidParameterError
from usvips.core.measure import Figure, QualityRules, polygon_figures, polyline_length
from usvips.core.rays import RayStatus
from usvips.io import tables
from usvips.io.calibration_file import load_calibration

COLUMNS = ("object", "type", "vertex", "xl", "yl", "xr", "yr")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("measure", help="measure objects from picks: figures with sigmas (CSV)")
    parser.add_argument("--calibration", required=True, help="calibration file (JSON)")
    parser.add_argument("--picks", required=True, help="picks CSV: object,type,vertex,xl,yl,xr,yr[,attribute]")
    parser.add_argument("--out", required=True, help="objects CSV to write")
    parser.add_argument("--station", default="0", help="calibrated station (index or label) for the frame")
    parser.add_argument("--frame", choices=["object", "rig"], default="object")
    parser.set_defaults(handler=run)


def read_picks(path: str | Path) -> list[dict]:
    """The picks file's rows, read and checked by :func:`usvips.io.tables.read_picks`."""
    return tables.read_picks(path)


def run(args: argparse.Namespace) -> int:
    calibration = load_calibration(args.calibration)
    rows = read_picks(args.picks)
    station = int(args.station) if args.station.isdigit() else args.station
    objects: dict[str, list[dict]] = {}
    for row in rows:
        objects.setdefault(row["object"], []).append(row)
    rules = QualityRules()
    out = []
    for object_id, vertices in objects.items():
        vertices.sort(key=lambda r: r["vertex"])
        kind = vertices[0]["type"]
        if any(v["type"] != kind for v in vertices):
            raise InputFileError(args.picks, f"object {object_id!r} mixes types", vertices[0]["line"])
        pixels = np.array([v["pixels"] for v in vertices])
        result, covariance = joint_covariance(calibration, pixels[:, :2], pixels[:, 2:], station, args.frame)
        failed = np.flatnonzero(~result.ok)
        if failed.size:
            bad = vertices[int(failed[0])]
            raise DegenerateGeometryError(f"{args.picks}, line {bad['line']}: object {object_id!r} vertex "
                                          f"{bad['vertex']}: {RayStatus(int(result.status[failed[0]])).reason}")
        points = result.points
        try:  # a figure that cannot be computed (too few vertices ...) is named by file, line and object
            if kind == "point":
                figure_name, value, sigma = "Z", points[0, 2], float(np.sqrt(covariance[2, 2]))
            elif kind == "line":
                figure = polyline_length(points, covariance)
                figure_name, value, sigma = "length", figure.value, figure.sigma
            else:
                figure = polygon_figures(points, covariance)["area"]
                figure_name, value, sigma = "area", figure.value, figure.sigma
        except (DegenerateGeometryError, InvalidParameterError) as error:
            raise InputFileError(args.picks, f"object {object_id!r}: {error}", vertices[0]["line"]) from None
        ray_rms = float(np.sqrt(np.mean(result.residuals_m**2)))
        ranges = float(np.max(np.linalg.norm(points - calibration.rig(station, args.frame).left.exterior.position,
                                             axis=1)))
        failures = rules.check(Figure(figure_name, value, sigma, "m"), ray_rms, ranges) if kind != "point" else []
        centre = points.mean(axis=0)
        out.append([object_id, kind, vertices[0]["attribute"], len(vertices), figure_name, f"{value:.6f}",
                    f"{sigma:.6f}", *(f"{c:.6f}" for c in centre), f"{ray_rms * 1000:.2f}", f"{ranges:.3f}",
                    "; ".join(failures)])
    write_text_atomic(args.out, csv_text(["object", "type", "attribute", "vertices", "figure", "value", "sigma",
                                          "X", "Y", "Z", "ray_rms_mm", "range_m", "quality"], out))
    print(f"measured {len(out)} objects; wrote {args.out}")
    return 0
