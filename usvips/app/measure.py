"""Measuring objects from a picks file: with a calibration file at a station and frame, or with the
calibration active for a project's pair and stored there (:func:`usvips.app.project_figures.
store_measurements`). The figures are those of the one figure path, ``usvips.core.measurements.
measure_picks``; rows for a table of them come from :func:`measurement_row`.

Picks file: ``object,type,vertex,xl,yl,xr,yr[,attribute]`` — pixels; ``type`` a measurement kind (point,
length, arc, polygon, circle, …; the legacy ``line`` is a length with two vertices, an arc with more);
rows of one object share its id and are ordered by ``vertex``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from usvips.app.project_figures import store_measurements
from usvips.core.errors import DegenerateGeometryError, InputFileError, UsvipsError
from usvips.core.measurements import Measurement, QualityRules, kind, measure_picks, resolve
from usvips.core.measurements.breakdown import BREAKDOWN_COLUMNS, breakdown_cells
from usvips.core.pointing import HAND_CLICK_SIGMA_PX, SOURCES
from usvips.core.stereo_calibration import StereoCalibration
from usvips.io import tables
from usvips.io.export import cell, number
from usvips.store.interface import ProjectStore

#: an object per picked object: (object id, registered kind, pixels (N, 4) xl yl xr yr, attribute)
PickedObject = tuple[str, str, np.ndarray, str]

#: the columns of a measured objects table (:func:`measurement_row`): X, Y, Z the vertices' centre (m),
#: the ray-intersection RMS in millimetres, the largest range from the left camera in metres, and the
#: sigma's breakdown (:data:`usvips.core.measurements.breakdown.BREAKDOWN_COLUMNS`)
MEASUREMENT_COLUMNS = ["object", "type", "attribute", "vertices", "figure", "value", "sigma", "X", "Y", "Z",
                       "ray_rms_mm", "range_m", "quality", *BREAKDOWN_COLUMNS]


def read_picks(path: str | Path) -> list[dict]:
    """The picks file's rows, read and checked by :func:`usvips.io.tables.read_picks`."""
    return tables.read_picks(path)


def group_picks(path: str | Path, rows: list[dict]) -> list[PickedObject]:
    """(object id, registered kind, pixels (N, 4) xl yl xr yr, attribute) per object, in file order; an
    object mixing types or with a count of vertices its kind refuses is an :class:`InputFileError` naming
    the file, the line and the object."""
    objects: dict[str, list[dict]] = {}
    for row in rows:
        objects.setdefault(row["object"], []).append(row)
    out = []
    for object_id, vertices in objects.items():
        other = next((v for v in vertices if v["type"] != vertices[0]["type"]), None)
        if other is not None:  # before the vertex numbers: two objects under one id is the likelier slip
            raise InputFileError(str(path), f"object {object_id!r} mixes types: {vertices[0]['type']} on line "
                                 f"{vertices[0]['line']}, {other['type']} on line {other['line']} (two objects "
                                 "under one id?)", vertices[0]["line"])
        vertices.sort(key=lambda r: r["vertex"])
        for previous, vertex in zip(vertices, vertices[1:], strict=False):
            if vertex["vertex"] == previous["vertex"]:
                raise InputFileError(str(path), f"object {object_id!r}: vertex {vertex['vertex']} is given twice "
                                     f"(lines {previous['line']} and {vertex['line']})", vertex["line"])
        written = vertices[0]["type"]
        try:
            name = resolve(written, len(vertices))
        except UsvipsError as error:
            raise InputFileError(str(path), f"object {object_id!r}: {error}", vertices[0]["line"]) from None
        try:
            kind(name).check_count(len(vertices))
        except UsvipsError as error:  # (a legacy type word is read as the kind its vertex count makes)
            count = f"{len(vertices)} vertex" if len(vertices) == 1 else f"{len(vertices)} vertices"
            read_as = f" (type {written!r} with {count} is read as {name})" if name != written else ""
            raise InputFileError(str(path), f"object {object_id!r}{read_as}: {error}", vertices[0]["line"]) from None
        out.append((object_id, name, np.array([v["pixels"] for v in vertices]), _attribute(path, object_id, vertices)))
    return out


def _attribute(path: str | Path, object_id: str, vertices: list[dict]) -> str:
    """The object's attribute: the one its rows give (on any of them; rows may leave it empty); two different
    attributes for one object is an :class:`InputFileError` naming both lines."""
    given = [v for v in vertices if v["attribute"]]
    other = next((v for v in given if v["attribute"] != given[0]["attribute"]), None)
    if other is not None:
        raise InputFileError(str(path), f"object {object_id!r} has two attributes: {given[0]['attribute']!r} on "
                             f"line {given[0]['line']}, {other['attribute']!r} on line {other['line']}",
                             other["line"])
    return given[0]["attribute"] if given else ""


def picked_objects(path: str | Path) -> list[PickedObject]:
    """The objects of the picks file at ``path`` (:func:`read_picks` then :func:`group_picks`)."""
    return group_picks(path, read_picks(path))


def measure_objects(calibration: StereoCalibration, objects: list[PickedObject], station: int | str = 0,
                    frame: str = "object", rules: QualityRules | None = None, where: str = "",
                    pointing_sigma_px: float | None = None) -> list[Measurement]:
    """Each object measured with ``calibration`` at ``station`` in ``frame`` ("object" or "rig"), its picks'
    pointing sigma ``pointing_sigma_px`` (px, one coordinate; None: the hand-click default). A vertex
    whose rays fail is a :class:`DegenerateGeometryError` naming ``where`` (e.g. the picks file) and the
    object."""
    measured = []
    for object_id, name, pixels, attribute in objects:
        try:
            measured.append(measure_picks(name, calibration, pixels[:, :2], pixels[:, 2:], station, frame, rules,
                                          id=object_id, attribute=attribute, pointing_sigma_px=pointing_sigma_px,
                                          pointing_origin="given"))
        except DegenerateGeometryError as error:
            prefix = f"{where}: " if where else ""
            raise DegenerateGeometryError(f"{prefix}object {object_id!r}: {error}") from None
    return measured


def measure_into_project(project: ProjectStore, pair: str, objects: list[PickedObject],
                         rules: QualityRules | None = None, where: str = "",
                         frame: int | None = None,
                         pointing_sigma_px: float | None = None) -> tuple[list[Measurement], list[int]]:
    """The objects measured with the calibration active for ``pair`` in the frame the pair measures in, and
    stored in ``project`` as the window stores them, all or none (:func:`usvips.app.project_figures.
    store_measurements`; ``pointing_sigma_px`` as there). ``frame``: ``pair`` is a stereo video's label and
    the picks are on its left frame ``frame`` (and the right frame synchronised with it), stored as the
    window stores a video frame's object. Returns the measurements and the new objects' ids."""
    video_frame = None
    if frame is not None:
        from usvips.app.video_project import left_frame_times, partner_frame

        video = project.video(pair)
        count = int(video.frame_count)
        if not 0 <= frame < count:
            raise UsvipsError(f"video {pair!r} has frames 0 to {count - 1}: there is no frame {frame}")
        partner = partner_frame(video, frame)
        video_frame = (pair, frame, partner, float(left_frame_times(project, pair, [frame])[0]))
    elif pair in {v.label for v in project.videos()}:  # its picks would belong to no frame
        raise UsvipsError(f"{project.path}: {pair!r} is a stereo video, not an image pair: measure on one of its "
                          "frames")
    return store_measurements(project, pair, objects, rules, where, pointing_sigma_px, video_frame)


def measurement_row(m: Measurement) -> list[str]:
    """A measurement as text cells in :data:`MEASUREMENT_COLUMNS` order."""
    centre = m.points.mean(axis=0)
    breakdown = breakdown_cells(m)
    return [cell(m.id), m.kind, cell(m.attribute), str(len(m.points)), m.main.name, number(m.main.value),
            number(m.main.sigma), *(number(c) for c in centre), number(m.ray_rms_m * 1000), number(m.range_m),
            "; ".join(m.failures), *(cell(breakdown[c]) for c in BREAKDOWN_COLUMNS)]


def pointing_line(m: Measurement | None, given: float | None) -> str:
    """The line a command prints about the pointing sigma its figures used: given, or the default for an
    unspecified source (and the calibration's marks, once)."""
    if given is not None:
        text = f"pointing sigma {given:g} px (given)"
    else:
        text = f"pointing sigma {HAND_CLICK_SIGMA_PX:g} px: the hand-click default ({SOURCES['hand click'].basis})"
    marks = [] if m is None else list(m.marks)
    return "; ".join([text, *marks])
