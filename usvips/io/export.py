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


def export(objects: list[MeasuredObject], path: str | Path, kind: str | None = None, **eventmeasure) -> None:
    """Write objects as ``csv`` (objects), ``vertices.csv``, ``geojson`` or ``ply``, by suffix or ``kind``;
    a path ending ``.em.txt`` writes the EventMeasure-style pair ``<name>_Lengths.txt`` and
    ``<name>_3DPoints.txt`` beside it (``eventmeasure``: the keywords of :func:`eventmeasure_tables`)."""
    path = Path(path)
    if path.name.endswith(".em.txt") or kind == "eventmeasure":
        stem = path.name[: -len(".em.txt")] if path.name.endswith(".em.txt") else path.stem
        lengths, points = eventmeasure_tables(objects, **eventmeasure)
        write_text_atomic(path.with_name(f"{stem}_Lengths.txt"), lengths)
        write_text_atomic(path.with_name(f"{stem}_3DPoints.txt"), points)
        return
    kind = kind or ("vertices" if path.name.endswith(".vertices.csv") else path.suffix.lstrip("."))
    writers = {"csv": objects_csv, "vertices": vertices_csv, "geojson": geojson, "json": geojson, "ply": ply}
    if kind not in writers:
        raise InvalidParameterError("format", f"unknown export format {kind!r}; use csv, vertices, geojson or ply")
    write_text_atomic(path, writers[kind](objects))


# --- EventMeasure-style tables (read by survey pipelines such as CheckEM) ------------------------------
# The headers are those of EventMeasure's "Lengths" and "3D Points" text exports as CheckEM's example data
# carry them (GlobalArchiveManual/CheckEM, inst/shiny/CheckEM/data/examples/*_Lengths.txt, *_3DPoints.txt):
# tab-separated, no units in the names, lengths, coordinates, precision, RMS and range in millimetres.
# CheckEM takes the campaign from the file name (before "_Lengths.txt") and the sample from OpCode, and
# by default keeps range < 10 m, RMS < 20 mm and precision/length < 10 %. Columns we have no value for
# (image point pair, time, period, HorzDir, VertDir, CAAB code, stage, activity) are left empty.

LENGTH_COLUMNS = ["OpCode", "ImagePtPair", "FilenameLeft", "FrameLeft", "FilenameRight", "FrameRight", "Time",
                  "Period", "PeriodTime", "Length", "Precision", "RMS", "Range", "Direction", "HorzDir", "VertDir",
                  "MidX", "MidY", "MidZ", "Family", "Genus", "Species", "Code", "Number", "Stage", "Activity",
                  "Comment", "Attribute9", "Attribute10"]
POINT_COLUMNS = ["OpCode", "ImagePtPair", "FilenameLeft", "FrameLeft", "FilenameRight", "FrameRight", "Time",
                 "Period", "PeriodTime", "X", "Y", "Z", "sX", "sY", "sZ", "RMS", "Range", "Direction", "Family",
                 "Genus", "Species", "Code", "Number", "Stage", "Activity", "Comment", "Attribute9", "Attribute10"]


def _taxonomy(attribute: str) -> tuple[str, str, str]:
    words = attribute.split()
    if len(words) == 3:
        return words[0], words[1], words[2]
    return "", "", attribute


def eventmeasure_tables(objects: list[MeasuredObject], opcode: str = "", camera_centre=(0.0, 0.0, 0.0),
                        rms_m: dict[str, float] | None = None,
                        images: dict[str, tuple[str, str, str, str]] | None = None) -> tuple[str, str]:
    """(lengths, 3-D points) as tab-separated text: two-vertex lines become lengths (snout to fork),
    points become 3-D points (their Direction left empty). ``rms_m``: each object's ray-intersection RMS
    (metres) if known (CheckEM drops rows without one when it filters on RMS); ``images``:
    object id → (left file, left frame, right file, right frame[, time (min), period, period time (min)]).
    Direction is the angle (degrees) between the measured line and the line of sight to its middle from
    ``camera_centre`` (90° = across the view);
    ``camera_centre`` is one point (m) for all objects or a mapping object id → point, since objects
    measured at different stations see the left camera at different places."""
    rms_m = rms_m or {}
    images = images or {}
    lengths = ["\t".join(LENGTH_COLUMNS)]
    points = ["\t".join(POINT_COLUMNS)]
    for obj in objects:
        centre = np.asarray(camera_centre[obj.id] if isinstance(camera_centre, dict) else camera_centre, float)
        family, genus, species = _taxonomy(obj.attribute)
        rms = f"{rms_m[obj.id] * 1000:.2f}" if obj.id in rms_m else ""
        file_left, frame_left, file_right, frame_right, *timing = images.get(obj.id, ("", "", "", ""))
        head = [opcode, "", file_left, frame_left, file_right, frame_right, *(list(timing) + ["", "", ""])[:3]]
        tail = [family, genus, species, "", "1", "", "", obj.notes.replace("\t", " ").replace("\n", " "), "", ""]
        if obj.kind == "line" and len(obj.points) == 2:
            figure = polyline_length(obj.points, obj.covariances)
            middle = obj.points.mean(axis=0)
            segment = obj.points[1] - obj.points[0]
            view = middle - centre
            direction = np.degrees(np.arccos(abs(segment @ view) / (np.linalg.norm(segment) * np.linalg.norm(view))))
            row = head + [f"{figure.value * 1000:.1f}", f"{figure.sigma * 1000:.1f}", rms,
                          f"{np.linalg.norm(view) * 1000:.0f}", f"{direction:.1f}", "", "",
                          *(f"{v * 1000:.1f}" for v in middle)] + tail
            lengths.append("\t".join(row))
        elif obj.kind == "point":
            p = obj.points[0]
            sigma = np.sqrt(np.diag(obj.covariances[0]))
            row = head + [*(f"{v * 1000:.1f}" for v in p), *(f"{v * 1000:.1f}" for v in sigma), rms,
                          f"{np.linalg.norm(p - centre) * 1000:.0f}", ""] + tail
            points.append("\t".join(row))
    return "\n".join(lengths) + "\n", "\n".join(points) + "\n"
