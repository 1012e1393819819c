"""Exporting a project's measured objects (objects CSV, vertices CSV, GeoJSON, PLY, EventMeasure-style
tables for CheckEM): joins the store (the objects, their picks and calibrations) to io's writers, for the
command line and the workstation alike.

The figures are those of :func:`usvips.app.project_figures.measure_stored` — recomputed from the picks with
the calibration each object was measured with, so with the joint covariance of its vertices — the very
function the window's object list and geo-calculator call: an exported s_length, the EventMeasure
Precision and the window's sigma are one number.
"""

from __future__ import annotations

from pathlib import Path

from usvips.app.project_figures import evaluate, measurement_input
from usvips.app.video_project import eventmeasure_frame_columns
from usvips.core.errors import UsvipsError
from usvips.core.measurements import QualityRules
from usvips.io.export import export
from usvips.store.interface import ProjectStore


def export_project(project: ProjectStore, out: str | Path, opcode: str | None = None,
                   rules: QualityRules | None = None, skipped: list[str] | None = None) -> int:
    """Write the project's objects that have figures to ``out`` (format by suffix, see
    :func:`usvips.io.export.export`); returns how many were written. Objects without figures (no 3-D
    vertices) are left out and named in ``skipped`` ("object N: why") when a list is given. ``opcode``
    (EventMeasure tables): default the project file's name. ``rules``: the quality rules (defaults)."""
    objects, centres, images, cache = [], {}, {}, {}
    pairs = {p["label"]: p for p in project.pairs()}
    for stored in project.objects():
        source = measurement_input(project, stored, cache)
        try:
            measurement = evaluate(source, rules)
        except UsvipsError as error:
            if skipped is not None:
                skipped.append(str(error))
            continue
        objects.append(measurement)
        if source.calibration is not None:
            centres[measurement.id] = source.calibration.rig(source.station, source.frame).left.exterior.position
        pair = pairs.get(source.pair)
        if pair is not None:
            frame = "" if pair["frame"] is None else str(pair["frame"])
            images[measurement.id] = (Path(pair["left"] or "").name, frame, Path(pair["right"] or "").name, frame)
        video_columns = eventmeasure_frame_columns(project, stored.vertices[0]) if stored.vertices else None
        if video_columns is not None:  # measured on a video: its files, frames, time and period
            images[measurement.id] = video_columns
    opcode = opcode if opcode is not None else project.path.stem
    records = {o.id: record for o in objects if (record := project.record(int(o.id))) is not None}
    export(objects, out, opcode=opcode, camera_centre={o.id: centres.get(o.id, (0.0, 0.0, 0.0)) for o in objects},
           images=images, records=records)
    return len(objects)
