"""``usvips measure``: objects from picks in a CSV, with their figures and sigmas, without a window.

Picks CSV: ``object,type,vertex,xl,yl,xr,yr[,attribute]`` — pixels; ``type`` point, line or polygon;
rows of one object share its id and are ordered by ``vertex``. Every vertex is intersected with the
calibration; the figures' sigmas carry the pointing and the calibration's own uncertainty, including
the correlation a common calibration puts between the vertices of one object.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from usvips.cli.common import csv_text, write_text_atomic
from usvips.core.calibration.uncertainty import joint_covariance
from usvips.core.errors import DegenerateGeometryError, InputFileError
from usvips.core.measure import KINDS, Figure, QualityRules, polygon_figures, polyline_length
from usvips.core.rays import RayStatus
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
    path = Path(path)
    if not path.is_file():
        raise InputFileError(str(path), "no such file")
    lines = [(n, line) for n, line in enumerate(path.read_text(encoding="utf-8-sig").splitlines(), 1)
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise InputFileError(str(path), "the file is empty")
    header = next(csv.reader([lines[0][1]]))
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise InputFileError(str(path), f"missing column(s) {', '.join(missing)} (expected {','.join(COLUMNS)})",
                             lines[0][0])
    rows = []
    for number, line in lines[1:]:
        fields = dict(zip(header, next(csv.reader([line])), strict=False))
        if fields["type"] not in KINDS:
            raise InputFileError(str(path), f"type {fields['type']!r} is not one of {', '.join(KINDS)}", number)
        try:
            values = [float(fields[c]) for c in ("xl", "yl", "xr", "yr")]
            vertex = int(fields["vertex"])
        except (TypeError, ValueError):
            raise InputFileError(str(path), "vertex and pixel columns must be numbers (both picks are needed)",
                                 number) from None
        if not np.all(np.isfinite(values)):
            raise InputFileError(str(path), "a vertex needs both picks (finite pixels)", number)
        rows.append({"object": fields["object"], "type": fields["type"], "vertex": vertex, "pixels": values,
                     "attribute": fields.get("attribute", ""), "line": number})
    return rows


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
        if kind == "point":
            figure_name, value, sigma = "Z", points[0, 2], float(np.sqrt(covariance[2, 2]))
        elif kind == "line":
            figure = polyline_length(points, covariance)
            figure_name, value, sigma = "length", figure.value, figure.sigma
        else:
            figure = polygon_figures(points, covariance)["area"]
            figure_name, value, sigma = "area", figure.value, figure.sigma
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
