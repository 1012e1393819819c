"""Exports of measured objects: CSV (objects with figures, and vertices), GeoJSON (3-D), PLY.

Objects are :class:`usvips.core.measure.MeasuredObject` (metres, project frame). Figures per object:
point — X, Y, Z; line — length; polygon — area, perimeter, planarity; each with its sigma. Files are
written atomically (a temporary file, then renamed).
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np

from usvips.core.errors import InvalidParameterError
from usvips.core.measure import MeasuredObject, polygon_figures, polyline_length
from usvips.io.atomic import write_text_atomic


def object_figures(obj: MeasuredObject) -> dict[str, tuple[float, float]]:
    """name → (value, sigma) for an object (metres, m²)."""
    if obj.kind == "point":
        sigmas = np.sqrt(np.diag(obj.covariances[0]))
        return {axis: (float(obj.points[0, k]), float(sigmas[k])) for k, axis in enumerate("XYZ")}
    if obj.kind == "line":
        figure = polyline_length(obj.points, obj.covariances)
        return {"length": (figure.value, figure.sigma)}
    figures = polygon_figures(obj.points, obj.covariances)
    return {name: (figures[name].value, figures[name].sigma) for name in ("area", "perimeter", "planarity_rms")}


OBJECT_COLUMNS = ["id", "kind", "attribute", "vertices", "X", "sX", "Y", "sY", "Z", "sZ", "length", "s_length",
                  "area", "s_area", "perimeter", "s_perimeter", "planarity_rms", "notes"]


def objects_csv(objects: list[MeasuredObject]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(OBJECT_COLUMNS)
    for obj in objects:
        figures = object_figures(obj)
        row = {"id": obj.id, "kind": obj.kind, "attribute": obj.attribute, "vertices": len(obj.points),
               "notes": obj.notes}
        for name, (value, sigma) in figures.items():
            row[name] = f"{value:.6f}"
            key = {"X": "sX", "Y": "sY", "Z": "sZ"}.get(name, f"s_{name}")
            if key in OBJECT_COLUMNS:
                row[key] = f"{sigma:.6f}"
        writer.writerow([row.get(c, "") for c in OBJECT_COLUMNS])
    return buffer.getvalue()


def vertices_csv(objects: list[MeasuredObject]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["object", "vertex", "X", "Y", "Z", "sX", "sY", "sZ"])
    for obj in objects:
        for i, (p, c) in enumerate(zip(obj.points, obj.covariances, strict=True)):
            writer.writerow([obj.id, i, *(f"{v:.6f}" for v in p), *(f"{v:.6f}" for v in np.sqrt(np.diag(c)))])
    return buffer.getvalue()


def geojson(objects: list[MeasuredObject]) -> str:
    """A FeatureCollection with 3-D coordinates (X, Y, Z in metres, the project frame — not WGS 84)."""
    features = []
    for obj in objects:
        coordinates = obj.points.tolist()
        if obj.kind == "point":
            geometry = {"type": "Point", "coordinates": coordinates[0]}
        elif obj.kind == "line":
            geometry = {"type": "LineString", "coordinates": coordinates}
        else:
            geometry = {"type": "Polygon", "coordinates": [coordinates + [coordinates[0]]]}
        properties = {"id": obj.id, "kind": obj.kind, "attribute": obj.attribute, "notes": obj.notes}
        properties.update({name: {"value": v, "sigma": s} for name, (v, s) in object_figures(obj).items()})
        features.append({"type": "Feature", "geometry": geometry, "properties": properties})
    return json.dumps({"type": "FeatureCollection", "crs_note": "project frame, metres", "features": features},
                      indent=1, allow_nan=False)


def ply(objects: list[MeasuredObject]) -> str:
    """ASCII PLY: every vertex, and the edges of lines and (closed) polygons."""
    vertices, edges = [], []
    for obj in objects:
        start = len(vertices)
        vertices.extend(obj.points.tolist())
        n = len(obj.points)
        links = [(i, i + 1) for i in range(n - 1)] if obj.kind != "point" else []
        if obj.kind == "polygon":
            links.append((n - 1, 0))
        edges.extend((start + a, start + b) for a, b in links)
    lines = ["ply", "format ascii 1.0", "comment USVIPS measured objects, metres, project frame",
             f"element vertex {len(vertices)}", "property double x", "property double y", "property double z",
             f"element edge {len(edges)}", "property int vertex1", "property int vertex2", "end_header"]
    lines += [f"{x:.6f} {y:.6f} {z:.6f}" for x, y, z in vertices]
    lines += [f"{a} {b}" for a, b in edges]
    return "\n".join(lines) + "\n"


def export(objects: list[MeasuredObject], path: str | Path, kind: str | None = None) -> None:
    """Write objects as ``csv`` (objects), ``vertices.csv``, ``geojson`` or ``ply``, by suffix or ``kind``."""
    path = Path(path)
    kind = kind or ("vertices" if path.name.endswith(".vertices.csv") else path.suffix.lstrip("."))
    writers = {"csv": objects_csv, "vertices": vertices_csv, "geojson": geojson, "json": geojson, "ply": ply}
    if kind not in writers:
        raise InvalidParameterError("format", f"unknown export format {kind!r}; use csv, vertices, geojson or ply")
    write_text_atomic(path, writers[kind](objects))
