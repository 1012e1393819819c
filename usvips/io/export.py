"""Exports of measured objects: CSV (objects with figures, and vertices), GeoJSON (RFC 7946, WGS 84, through
the project's georeference), PLY (ASCII or binary, with sigmas and attributes per vertex), and
EventMeasure-style tab-separated tables with CheckEM's sample metadata.

Objects are :class:`usvips.core.measurements.Measurement` (metres, project frame): their figures and
sigmas were computed by the one figure path (``usvips.core.measurements.measure``); nothing here
computes a figure. The columns of the objects CSV are the figures of every registered measurement kind
(``X, sX, …, length, s_length, …``), so a new kind brings its columns with it.

Every table is written with the :mod:`csv` module (the tab dialect for EventMeasure) and every text
cell is sanitised (:func:`cell`): a tab or newline in an attribute, note or OpCode never shifts a column,
and a cell starting with ``= + - @`` is neutralised for spreadsheets while numbers stay numbers. A set of
files is written all or nothing (:func:`usvips.io.atomic.write_files_atomic`).
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np

from usvips.core.deployment import Deployment, Georeference
from usvips.core.errors import InvalidParameterError
from usvips.core.measurements import Measurement, registered_kinds
from usvips.core.measurements import kind as measurement_kind
from usvips.core.measurements.breakdown import BREAKDOWN_COLUMNS, breakdown_cells
from usvips.core.observation_record import ObservationRecord
from usvips.io.atomic import write_bytes_atomic, write_files_atomic
from usvips.io.checkem import METADATA_COLUMNS, metadata_rows
from usvips.io.georeference import meridian_crossing, object_to_geographic

#: Characters that make a spreadsheet read a cell as a formula (and tab / carriage return, which some
#: spreadsheets strip before looking) — OWASP's CSV-injection list.
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def cell(value: object, flatten: bool = False) -> str:
    """A table cell: numbers as they are — a number that is not finite (NaN, ±inf: unknown) empty, never
    the text "nan" or "inf"; text with a leading ``'`` when it would start a formula (``=1+1`` → ``'=1+1``;
    ``-0.5`` stays a number), and with ``flatten`` (tab-separated tables, read by tools that do not honour
    quotes) tabs and line breaks replaced by spaces. A table's mandatory number is checked by its writer
    (:func:`mandatory_number`), which refuses it by name rather than leave it empty."""
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return number(value) if np.isfinite(value) else ""
    text = "" if value is None else str(value)
    if flatten:
        text = " ".join(text.replace("\r\n", "\n").replace("\r", "\n").replace("\t", " ").split("\n"))
    if text.startswith(FORMULA_START) and not _is_number(text):
        text = "'" + text
    return text


def mandatory_number(value: float, column: str, object_id: object, table: str) -> float:
    """``value`` when it is a finite number; else one line naming the object, the table and its mandatory
    ``column`` (a table without it would be refused, or misread, by the tools that read it)."""
    if not np.isfinite(value):
        raise InvalidParameterError(column, f"object {object_id}: its {column} is not a finite number ({value!r}), "
                                    f"and the {table} table needs one")
    return float(value)


def number(value: float) -> str:
    """A float as the shortest text that reads back to the same float (no rounding: the exported
    figures equal the window's)."""
    return repr(float(value))


def _table(header: list[str], rows: list[list], dialect: str = "excel", flatten: bool = False) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, dialect=dialect, lineterminator="\n")
    writer.writerow([cell(h, flatten) for h in header])
    writer.writerows([[cell(v, flatten) if v != "" else "" for v in row] for row in rows])
    return buffer.getvalue()


def _sigma_column(name: str) -> str:
    return f"s{name}" if name in ("X", "Y", "Z") else f"s_{name}"


def figure_columns() -> list[str]:
    """Value and sigma columns of every registered kind's figures, in registry order, each once."""
    columns: list[str] = []
    for measurement in registered_kinds():
        for name, _ in measurement.figure_names:
            if name not in columns:
                columns.append(name)
    return [c for name in columns for c in (name, _sigma_column(name))]


#: where and what an object is: its observation record's species (Genus species), code and number, the
#: pair (or video) it was measured on, the image files and frames (a video's chapter files and frame numbers
#: within them) and, on a video, the time in minutes from the recording's start (EventMeasure's Time)
RECORD_COLUMNS = ["species", "code", "number"]
PLACE_COLUMNS = ["pair", "file_left", "frame_left", "file_right", "frame_right", "time_min"]


def object_columns() -> list[str]:
    return (["id", "kind"] + RECORD_COLUMNS + ["attribute", "vertices"] + figure_columns() + BREAKDOWN_COLUMNS
            + ["ray_rms_m", "range_m", "covariance", "quality", "instants", "notes"] + PLACE_COLUMNS)


def _covariance_word(obj: Measurement) -> str:
    return "joint" if obj.joint else "per-vertex"


def objects_csv(objects: list[Measurement], records: dict | None = None, places: dict | None = None) -> str:
    """One row per object: its species, code and number (``records``: object id → observation record),
    its figures with sigmas (metres, m², radians), the main figure's sigma broken down (pointing share,
    calibration share, the vertices' pointing sigma in px and its origin, notes on the sigma:
    :data:`~usvips.core.measurements.breakdown.BREAKDOWN_COLUMNS`), ray RMS and range (m) when known,
    whether the sigmas come from the joint covariance, the quality rules it breaks, and where it was
    measured (``places``:
    object id → (pair, file left, frame left, file right, frame right, time in minutes); see
    :data:`PLACE_COLUMNS`)."""
    columns = object_columns()
    rows = []
    for obj in objects:
        row = {"id": obj.id, "kind": obj.kind, "attribute": obj.attribute, "vertices": len(obj.points),
               "notes": obj.notes, "covariance": _covariance_word(obj), "quality": "; ".join(obj.failures),
               "instants": obj.instant_count}
        record = (records or {}).get(obj.id)
        if record is not None:
            row.update({"species": record.name, "code": record.code, "number": record.number})
        row.update(zip(PLACE_COLUMNS, (places or {}).get(obj.id, ()), strict=False))
        row.update({"ray_rms_m": obj.ray_rms_m, "range_m": obj.range_m})
        row.update(breakdown_cells(obj))
        for figure in obj.figures:
            row[figure.name] = figure.value
            row[_sigma_column(figure.name)] = figure.sigma
        rows.append(["" if row.get(c) is None else row.get(c, "") for c in columns])
    return _table(columns, rows)


def vertices_csv(objects: list[Measurement]) -> str:
    """One row per vertex: X, Y, Z and their sigmas (m)."""
    rows = []
    for obj in objects:
        for i, (p, s) in enumerate(zip(obj.points, obj.vertex_sigmas, strict=True)):
            rows.append([obj.id, i, *p, *s])
    return _table(["object", "vertex", "X", "Y", "Z", "sX", "sY", "sZ"], rows)


_GEOJSON = {"marker": "Point", "polyline": "LineString", "polygon": "Polygon", "circle": "Polygon"}


def _counter_clockwise(ring: np.ndarray) -> np.ndarray:
    """A closed lon/lat ring (N, ≥2) wound counter-clockwise (RFC 7946's right-hand rule for exterior
    rings): the shoelace sign on longitude scaled by cos(latitude)."""
    x = ring[:, 0] * np.cos(np.radians(ring[:, 1].mean()))
    y = ring[:, 1]
    signed = np.sum(x[:-1] * y[1:] - x[1:] * y[:-1])
    return ring if signed >= 0 else ring[::-1]


def _unwrapped(lonlat: np.ndarray) -> np.ndarray:
    """Longitudes made continuous from the first vertex (a feature of a few metres that straddles the
    antimeridian gets longitudes beyond ±180 instead of a jump of 360°)."""
    out = np.array(lonlat, dtype=np.float64)
    out[:, 0] = out[0, 0] + (out[:, 0] - out[0, 0] + 180.0) % 360.0 - 180.0
    return out


def _crossing_meridian(unwrapped: np.ndarray) -> float | None:
    """The antimeridian (+180 or −180 in unwrapped longitudes) a feature crosses, or None."""
    for meridian in (180.0, -180.0):
        side = unwrapped[:, 0] - meridian
        if side.min() < 0 < side.max():
            return meridian
    return None


def _wrapped(part: np.ndarray) -> np.ndarray:
    """Longitudes back into [−180, 180], a vertex on the cut staying on its part's side (+180 or −180)."""
    part = np.array(part, dtype=np.float64)
    middle = float(np.mean(part[:, 0]))
    shift = 360.0 * np.round(middle / 360.0)
    part[:, 0] -= shift
    return part


def _on_cut(a: np.ndarray, b: np.ndarray, meridian: float) -> np.ndarray:
    """The point of the geodesic a→b (unwrapped lon, lat, height) on the meridian; its height
    interpolated along the geodesic."""
    latitude, fraction = meridian_crossing(a[:2], b[:2], meridian)
    return np.array([meridian, latitude, *(a[2:] + fraction * (b[2:] - a[2:]))])


def _cut_line(unwrapped: np.ndarray, meridian: float) -> list[np.ndarray]:
    """A line string cut where it crosses the meridian: its parts, each on one side."""
    parts, current = [], [unwrapped[0]]
    for a, b in zip(unwrapped[:-1], unwrapped[1:], strict=True):
        if (a[0] - meridian) * (b[0] - meridian) < 0:
            cut = _on_cut(a, b, meridian)
            parts.append(np.array([*current, cut]))
            current = [cut]
        current.append(b)
    parts.append(np.array(current))
    return [_wrapped(part) for part in parts if len(part) >= 2]


def _clip_ring(ring: np.ndarray, meridian: float, keep_west: bool) -> np.ndarray | None:
    """The part of a closed ring west (or east) of the meridian (Sutherland–Hodgman against one line),
    closed again; None when nothing is left."""
    inside = (lambda p: p[0] <= meridian) if keep_west else (lambda p: p[0] >= meridian)  # noqa: E731
    out = []
    points = ring[:-1]
    for i, current in enumerate(points):
        previous = points[i - 1]
        if inside(current):
            if not inside(previous):
                out.append(_on_cut(previous, current, meridian))
            out.append(current)
        elif inside(previous):
            out.append(_on_cut(previous, current, meridian))
    if len(out) < 3:
        return None
    out.append(out[0])
    return np.array(out)


def _geometry(kind: str, lonlat: np.ndarray) -> dict:
    """A GeoJSON geometry of lon/lat/height vertices; RFC 7946 §3.1.9: a feature that crosses the
    antimeridian is cut there into a MultiLineString or MultiPolygon, each part within [−180, 180]."""
    if kind == "Point":
        return {"type": "Point", "coordinates": lonlat[0].tolist()}
    unwrapped = _unwrapped(lonlat)
    meridian = _crossing_meridian(unwrapped)
    if kind == "LineString":
        if meridian is None:
            return {"type": "LineString", "coordinates": _wrapped(unwrapped).tolist()}
        return {"type": "MultiLineString", "coordinates": [p.tolist() for p in _cut_line(unwrapped, meridian)]}
    if meridian is None:
        return {"type": "Polygon", "coordinates": [_counter_clockwise(_wrapped(unwrapped)).tolist()]}
    parts = [_clip_ring(unwrapped, meridian, keep_west) for keep_west in (True, False)]
    return {"type": "MultiPolygon",
            "coordinates": [[_counter_clockwise(_wrapped(part)).tolist()] for part in parts if part is not None]}


def placed_point(obj: Measurement) -> tuple[np.ndarray, np.ndarray]:
    """A one-vertex object's place and its sigmas (m, the object's frame): its X, Y, Z figures when it was
    measured on several instants (combined over them; its vertex is its first instant's), else its vertex."""
    named = {f.name: f for f in obj.figures}
    if obj.instant_count > 1 and all(a in named for a in "XYZ"):
        return tuple(np.array([getattr(named[a], part) for a in "XYZ"]) for part in ("value", "sigma"))
    return np.asarray(obj.points[0], float), np.asarray(obj.vertex_sigmas[0], float)


def _feature_properties(obj: Measurement) -> dict:
    """Flat properties a GIS shows as columns: the object's id, kind, attribute and notes, every figure
    and its sigma (the objects CSV's names and units; combined over its instants when it has several),
    ray RMS and range (m), the quality rules it breaks, and its number of instants (the objects CSV's
    ``instants``)."""
    properties = {"id": obj.id, "kind": obj.kind, "attribute": obj.attribute, "notes": obj.notes,
                  "covariance": _covariance_word(obj), "quality": "; ".join(obj.failures)}
    for figure in obj.figures:
        properties[figure.name] = figure.value
        properties[_sigma_column(figure.name)] = figure.sigma
    properties.update({"ray_rms_m": obj.ray_rms_m, "range_m": obj.range_m, "instants": obj.instant_count})
    properties.update(breakdown_cells(obj))
    return properties


def geojson(objects: list[Measurement], georeference: Georeference | None = None) -> str:
    """An RFC 7946 FeatureCollection: WGS 84 longitude, latitude and height (m, −depth) through the
    project's ``georeference`` (:mod:`usvips.io.georeference`); a point, a line string, a polygon (its
    exterior ring counter-clockwise), a circle as the polygon of its fitted outline, each cut at the
    antimeridian where it crosses it (:func:`_geometry`); figures, sigmas and
    units as properties (:func:`_feature_properties`). An object measured on several instants is one
    feature: its combined figures and number of instants, drawn where its first instant was (a point at
    its combined place, :func:`placed_point`). Without a georeference there are no longitudes
    and latitudes to write: an :class:`InvalidParameterError` says to set one or to export CSV."""
    if georeference is None:
        raise InvalidParameterError("georeference", "GeoJSON holds WGS 84 longitude/latitude and this project has "
                                    "no georeference; set one (usvips project set-georeference, or File › "
                                    "Deployment and georeference… in the window) or export CSV (.csv, "
                                    ".vertices.csv) for the project frame's metres")
    features, units = [], {}
    for obj in objects:
        measurement = measurement_kind(obj.kind)
        drawing = measurement.drawing
        if drawing in ("marker", "polyline"):
            points = placed_point(obj)[0][None, :] if drawing == "marker" else obj.points
            geometry = _geometry(_GEOJSON[drawing], object_to_geographic(georeference, points))
        else:
            outline = np.asarray(measurement.outline(obj.points), float)
            if not np.array_equal(outline[0], outline[-1]):
                outline = np.vstack([outline, outline[:1]])
            geometry = _geometry(_GEOJSON[drawing], object_to_geographic(georeference, outline))
        units.update({f.name: f.unit for f in obj.figures})
        features.append({"type": "Feature", "id": obj.id, "geometry": geometry,
                         "properties": _feature_properties(obj)})
    g = georeference
    return json.dumps({"type": "FeatureCollection", "features": features,
                       "usvips": {"units": units, "height": "metres up from the sea surface (-depth)",
                                  "georeference": {"latitude": g.latitude, "longitude": g.longitude,
                                                   "depth_m": g.depth_m, "heading_deg": g.heading_deg}}},
                      indent=1, allow_nan=False)


#: PLY's kind property: an index into the registered kinds, named in the header's comments.
def _kind_codes() -> dict[str, int]:
    return {measurement.name: i for i, measurement in enumerate(registered_kinds())}


_PLY_VERTEX = [("x", "f8", "double"), ("y", "f8", "double"), ("z", "f8", "double"), ("sx", "f8", "double"),
               ("sy", "f8", "double"), ("sz", "f8", "double"), ("object", "i4", "int"), ("vertex", "i4", "int"),
               ("kind", "u1", "uchar"), ("ray_rms", "f8", "double"), ("main", "f8", "double"),
               ("s_main", "f8", "double")]


def ply_vertices(objects: list[Measurement]) -> tuple[np.ndarray, np.ndarray]:
    """The PLY vertex records (a structured array, :data:`_PLY_VERTEX`) and edges (M, 2) of objects: every
    vertex with its sigmas (m; a circle's vertices are its fitted outline, with the sigmas of its picked
    vertices' mean), its object (id; the position in the list when the id is not a whole number), its index
    in the object, its kind (:func:`_kind_codes`), the object's ray RMS (m; NaN when unknown) and main
    figure with its sigma; edges along polylines, closed around polygons and circles."""
    codes = _kind_codes()
    records, edges = [], []
    for number, obj in enumerate(objects):
        measurement = measurement_kind(obj.kind)
        if measurement.drawing == "circle":
            points = np.asarray(measurement.outline(obj.points), float)[:-1]
            sigmas = np.repeat(np.asarray(obj.vertex_sigmas, float).mean(axis=0, keepdims=True), len(points), axis=0)
        else:
            points, sigmas = np.asarray(obj.points, float), np.asarray(obj.vertex_sigmas, float)
        object_id = int(obj.id) if str(obj.id).isdigit() else number
        rms = np.nan if obj.ray_rms_m is None else obj.ray_rms_m
        start = len(records)
        records += [(*p, *sg, object_id, i, codes[obj.kind], rms, obj.main.value, obj.main.sigma)
                    for i, (p, sg) in enumerate(zip(points, sigmas, strict=True))]
        n = len(points)
        links = [(i, i + 1) for i in range(n - 1)] if measurement.drawing != "marker" else []
        if measurement.closes and n > 2:
            links.append((n - 1, 0))
        edges.extend((start + a, start + b) for a, b in links)
    vertices = np.array(records, dtype=[(name, kind) for name, kind, _ in _PLY_VERTEX])
    return vertices, np.array(edges, dtype="<i4").reshape(-1, 2)


def _ply_header(objects: list[Measurement], form: str, vertices: int, edges: int) -> str:
    lines = ["ply", f"format {form} 1.0", "comment USVIPS measured objects: metres, project frame; sx sy sz: "
             "standard deviations (m); ray_rms (m, nan when unknown); main, s_main: the kind's main figure and its "
             "sigma (m, m^2)"]
    lines += [f"comment kind {code} {name}" for name, code in _kind_codes().items()]
    lines += [f"comment object {cell(obj.id, True)} attribute {cell(obj.attribute, True)}" for obj in objects
              if obj.attribute]
    lines += [f"element vertex {vertices}"] + [f"property {ply_type} {name}" for name, _, ply_type in _PLY_VERTEX]
    lines += [f"element edge {edges}", "property int vertex1", "property int vertex2", "end_header"]
    return "\n".join(lines) + "\n"


def ply(objects: list[Measurement]) -> str:
    """ASCII PLY: every vertex with its sigmas and attributes (:func:`ply_vertices`) and the edges of
    polylines, (closed) polygons and circles."""
    vertices, edges = ply_vertices(objects)
    rows = [" ".join(number(v) if isinstance(v, float) else str(v) for v in record.tolist()) for record in vertices]
    rows += [f"{a} {b}" for a, b in edges]
    return _ply_header(objects, "ascii", len(vertices), len(edges)) + "".join(row + "\n" for row in rows)


def ply_binary(objects: list[Measurement]) -> bytes:
    """Binary little-endian PLY with the same elements and properties as :func:`ply`."""
    vertices, edges = ply_vertices(objects)
    little = vertices.astype(vertices.dtype.newbyteorder("<"))
    return (_ply_header(objects, "binary_little_endian", len(vertices), len(edges)).encode("ascii")
            + little.tobytes() + edges.astype("<i4").tobytes())


def eventmeasure_paths(path: str | Path) -> dict[str, Path]:
    """Table name → file of the EventMeasure-style set for ``path`` (``survey.em.txt`` →
    ``survey_Lengths.txt``, ``survey_3DPoints.txt``, a table per kind that has its own, and CheckEM's
    sample metadata ``survey_Metadata.csv``)."""
    path = Path(path)
    stem = path.name[: -len(".em.txt")] if path.name.endswith(".em.txt") else path.stem
    files = {table: path.with_name(f"{stem}_{table}.txt") for table in eventmeasure_table_names()}
    files["Metadata"] = path.with_name(f"{stem}_Metadata.csv")
    return files


def export(objects: list[Measurement], path: str | Path, kind: str | None = None,
           georeference: Georeference | None = None, places: dict | None = None, **eventmeasure) -> list[Path]:
    """Write objects as ``csv`` (objects), ``vertices.csv``, ``geojson`` (needs ``georeference``),
    ``ply`` (ASCII) or ``binary.ply`` (a name ending ``.binary.ply``), by suffix or ``kind``; a path
    ending ``.em.txt`` writes the EventMeasure-style set (:func:`eventmeasure_paths`) beside it, all files
    or none (``eventmeasure``: the keywords of :func:`eventmeasure_tables`; its ``records`` also fill the
    objects CSV's species columns, ``places`` its place columns). Returns the files written."""
    path = Path(path)
    if path.name.endswith(".em.txt") or kind == "eventmeasure":
        tables = eventmeasure_tables(objects, **eventmeasure)
        files = {target: tables[table] for table, target in eventmeasure_paths(path).items()}
        write_files_atomic(files)
        return list(files)
    if kind is None:
        kind = next((k for k, suffix in (("vertices", ".vertices.csv"), ("binary.ply", ".binary.ply"))
                     if path.name.endswith(suffix)), path.suffix.lstrip("."))
    writers = {"csv": lambda o: objects_csv(o, eventmeasure.get("records"), places),
               "vertices": vertices_csv, "ply": ply,
               "geojson": lambda o: geojson(o, georeference), "json": lambda o: geojson(o, georeference)}
    if kind == "binary.ply":
        write_bytes_atomic(path, ply_binary(objects))
        return [path]
    if kind not in writers:
        raise InvalidParameterError("format", f"unknown export format {kind!r}; use csv, vertices, geojson, ply, "
                                              "binary.ply or a name ending .em.txt (EventMeasure)")
    write_files_atomic({path: writers[kind](objects)})
    return [path]


# --- EventMeasure-style tables (read by survey pipelines such as CheckEM) ------------------------------
# The headers are those of EventMeasure's "Lengths" and "3D Points" text exports as CheckEM's example data
# carry them (GlobalArchiveManual/CheckEM, inst/shiny/CheckEM/data/examples/*_Lengths.txt, *_3DPoints.txt):
# tab-separated, no units in the names, lengths, coordinates, precision, RMS and range in millimetres.
# CheckEM takes the campaign from the file name (before "_Lengths.txt") and the sample from OpCode, and
# by default keeps range < 10 m, RMS < 20 mm and precision/length < 10 %. Columns we have no value for
# (image point pair, time, period, HorzDir, VertDir, CAAB code, stage, activity) are left empty.
# EventMeasure's lengths are two-point; an arc (polyline) goes to the lengths table as its length along
# the polyline, its Direction and Mid from the chord between its ends, its Comment saying "arc of N
# vertices" so that a reader can tell it. Kinds EventMeasure has no table for (polygons, circles) get a
# table of their own, NAME_Polygons.txt, NAME_Circles.txt: the same image and taxonomy columns, then every
# figure of the kind in millimetres (mm², degrees) with its sigma, "s" before the name.

LENGTH_COLUMNS = ["OpCode", "ImagePtPair", "FilenameLeft", "FrameLeft", "FilenameRight", "FrameRight", "Time",
                  "Period", "PeriodTime", "Length", "Precision", "RMS", "Range", "Direction", "HorzDir", "VertDir",
                  "MidX", "MidY", "MidZ", "Family", "Genus", "Species", "Code", "Number", "Stage", "Activity",
                  "Comment", "Attribute9", "Attribute10"]
POINT_COLUMNS = ["OpCode", "ImagePtPair", "FilenameLeft", "FrameLeft", "FilenameRight", "FrameRight", "Time",
                 "Period", "PeriodTime", "X", "Y", "Z", "sX", "sY", "sZ", "RMS", "Range", "Direction", "Family",
                 "Genus", "Species", "Code", "Number", "Stage", "Activity", "Comment", "Attribute9", "Attribute10"]
_HEAD = ["OpCode", "ImagePtPair", "FilenameLeft", "FrameLeft", "FilenameRight", "FrameRight", "Time", "Period",
         "PeriodTime"]
_TAIL = ["Family", "Genus", "Species", "Code", "Number", "Stage", "Activity", "Comment", "Attribute9", "Attribute10"]
_SCALE = {"m": 1000.0, "m²": 1e6, "rad": 180.0 / np.pi, "1": 1.0}


def eventmeasure_table_names() -> list[str]:
    """Lengths, 3DPoints, then the tables of their own that registered kinds ask for."""
    names = ["Lengths", "3DPoints"]
    for measurement in registered_kinds():
        if measurement.eventmeasure not in names:
            names.append(measurement.eventmeasure)
    return names


def _own_columns(table: str) -> list[str]:
    figures: list[str] = []
    for measurement in registered_kinds():
        if measurement.eventmeasure == table:
            figures += [n for n, _ in measurement.figure_names if n not in figures]
    columns = [c for name in figures for c in (_camel(name), f"s{_camel(name)}")]
    return _HEAD + ["Vertices", *columns, "RMS", "Range", "MidX", "MidY", "MidZ"] + _TAIL


def _camel(name: str) -> str:
    return "".join(part[:1].upper() + part[1:] for part in name.split("_"))


def _taxonomy(attribute: str) -> tuple[str, str, str]:
    """Family, genus, species of a free-text attribute when no observation record says them: "Family
    Genus species" (three words, the family's name ending as zoological and botanical families' do, -idae
    or -aceae: "left side only" is no taxon), "Genus species" (a binomial, two words); anything else stays
    whole in Species. Records typed from the species list (:class:`ObservationRecord`) are used instead when
    given."""
    words = attribute.split()
    if len(words) == 3 and words[0].lower().endswith(("idae", "aceae")) and words[1][:1].isupper():
        return words[0], words[1], words[2]
    if len(words) == 2 and words[0][:1].isupper() and words[1][:1].islower():
        return "", words[0], words[1]
    return "", "", attribute


def _record_columns(obj: Measurement, record: ObservationRecord | None, comment: str) -> list:
    """EventMeasure's Family … Attribute10 of one object: from its observation record when it has one
    (the comment joins the record's and the object's own), else the taxonomy read from the attribute."""
    if record is None:
        family, genus, species = _taxonomy(obj.attribute)
        return [family, genus, species, "", 1, "", "", comment, "", ""]
    comment = "; ".join(filter(None, [record.comment, comment]))
    return [record.family, record.genus, record.species, record.code, record.number, record.stage,
            record.activity, comment, "", ""]


def eventmeasure_tables(objects: list[Measurement], opcode: str | dict[str, str] = "", camera_centre=(0.0, 0.0, 0.0),
                        images: dict[str, tuple[str, ...]] | None = None,
                        records: dict[str, ObservationRecord] | None = None,
                        samples: list[tuple[Deployment, str]] | None = None) -> dict[str, str]:
    """Table name (:func:`eventmeasure_table_names`) → tab-separated text. Lengths and arcs become lengths
    (Length and Precision are the length figure and its sigma, in mm; an object combined over several
    instants says "mean of N instants" in its Comment; a point so combined is its combined place,
    :func:`placed_point`), points 3-D points (Direction
    empty), other kinds rows of their own table. RMS: the object's ray-intersection RMS (mm) when known
    (CheckEM drops rows without one when it filters on RMS); ``images``: object id → (left file, left
    frame, right file, right frame[, time (min), period, period time (min)]). Direction is the angle
    (degrees) between the measured line and the line of sight to its middle from ``camera_centre`` (90° =
    across the view); ``camera_centre`` is one point (m) for all objects or a mapping object id → point.
    ``records``: object id → its observation record (taxon, code, number, stage, activity, comment).
    ``opcode``: one for all objects or a mapping object id → OpCode. ``samples``: the (deployment,
    period) samples of CheckEM's ``Metadata`` table (:mod:`usvips.io.checkem`), measured on or not; a
    sample of an exported row that they do not hold gets a row of its own (the metadata of a deployment
    with its OpCode, else the OpCode and Period only), so that every measurement has its sample there."""
    images = images or {}
    records = records or {}
    rows: dict[str, list[list]] = {name: [] for name in eventmeasure_table_names()}
    for obj in objects:
        centre = np.asarray(camera_centre[obj.id] if isinstance(camera_centre, dict) else camera_centre, float)
        rms = "" if obj.ray_rms_m is None else obj.ray_rms_m * 1000
        file_left, frame_left, file_right, frame_right, *timing = images.get(obj.id, ("", "", "", ""))
        sample = opcode.get(obj.id, "") if isinstance(opcode, dict) else opcode
        head = [sample, "", file_left, frame_left, file_right, frame_right, *(list(timing) + ["", "", ""])[:3]]
        comment = obj.notes
        if obj.instant_count > 1:  # CheckEM: one length, its precision and the number of instants
            comment = f"mean of {obj.instant_count} instants" + (f"; {comment}" if comment else "")
        table = measurement_kind(obj.kind).eventmeasure
        if table == "Lengths":
            if len(obj.points) > 2:
                comment = f"{obj.kind} of {len(obj.points)} vertices" + (f"; {comment}" if comment else "")
            length = obj.main
            mandatory_number(length.value, "Length", obj.id, "EventMeasure Lengths")
            ends = obj.points[[0, -1]]
            middle = ends.mean(axis=0)
            segment, view = ends[1] - ends[0], middle - centre
            scale = np.linalg.norm(segment) * np.linalg.norm(view)
            direction = np.degrees(np.arccos(min(1.0, abs(segment @ view) / scale))) if scale > 0 else ""
            rows[table].append(head + [length.value * 1000, length.sigma * 1000, rms, np.linalg.norm(view) * 1000,
                                       direction, "", "", *(middle * 1000)]
                               + _record_columns(obj, records.get(obj.id), comment))
        elif table == "3DPoints":
            p, sigma = placed_point(obj)
            for axis, coordinate in zip("XYZ", p, strict=True):
                mandatory_number(coordinate, axis, obj.id, "EventMeasure 3DPoints")
            rows[table].append(head + [*(p * 1000), *(sigma * 1000), rms, np.linalg.norm(p - centre) * 1000, ""]
                               + _record_columns(obj, records.get(obj.id), comment))
        else:
            values = {}
            for f in obj.figures:
                values[_camel(f.name)] = f.value * _SCALE.get(f.unit, 1.0)
                values[f"s{_camel(f.name)}"] = f.sigma * _SCALE.get(f.unit, 1.0)
            middle = obj.points.mean(axis=0)
            columns = _own_columns(table)
            figures = [values.get(c, "") for c in columns[len(_HEAD) + 1:-len(_TAIL) - 5]]
            rows[table].append(head + [len(obj.points), *figures, rms,
                                       np.linalg.norm(middle - centre) * 1000, *(middle * 1000)]
                               + _record_columns(obj, records.get(obj.id), comment))
    headers = {"Lengths": LENGTH_COLUMNS, "3DPoints": POINT_COLUMNS}
    tables = {name: _table(headers.get(name) or _own_columns(name), table_rows, "excel-tab", flatten=True)
              for name, table_rows in rows.items()}
    measured = list(samples or [])
    known = {(d.opcode, period) for d, period in measured}
    deployments = {d.opcode: d for d, _ in measured}
    for table_rows in rows.values():
        for row in table_rows:
            opcode_cell, period = cell(row[0], flatten=True).strip(), cell(row[7], flatten=True).strip()
            if opcode_cell and (opcode_cell, period) not in known:
                known.add((opcode_cell, period))
                measured.append((deployments.get(opcode_cell) or Deployment(opcode_cell), period))
    tables["Metadata"] = _table(METADATA_COLUMNS, metadata_rows(measured))
    return tables
