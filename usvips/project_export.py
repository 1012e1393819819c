"""Exporting a project's measured objects (objects CSV, vertices CSV, GeoJSON, PLY, EventMeasure-style
tables for CheckEM): joins the store (the objects, their picks and calibrations) to io's writers, for the
command line and the workstation alike."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from usvips.core.errors import UsvipsError
from usvips.core.intersection import intersect
from usvips.core.measure import MeasuredObject
from usvips.io.calibration_file import calibration_from_dict
from usvips.io.export import export
from usvips.store import Project
from usvips.video_project import eventmeasure_frame_columns


def _ray_geometry(project: Project, stored, cache: dict) -> tuple[float, np.ndarray] | None:
    """The ray-intersection RMS (m) of an object's vertices and the left camera's centre (m), from the
    calibration and pair it was measured with; None when that is not known."""
    keys = {(v.calibration_id, v.pair) for v in stored.vertices}
    if len(keys) != 1 or None in next(iter(keys)):
        return None
    calibration_id, label = next(iter(keys))
    if calibration_id not in cache:
        try:
            cache[calibration_id] = calibration_from_dict(project.calibration(calibration_id))
        except UsvipsError:
            cache[calibration_id] = None
    calibration = cache[calibration_id]
    if calibration is None:
        return None
    station, frame = (label, "object") if label in calibration.stations else (0, "rig")
    rig = calibration.rig(station, frame)
    left = np.array([[v.xl, v.yl] for v in stored.vertices])
    right = np.array([[v.xr, v.yr] for v in stored.vertices])
    result = intersect(rig.cameras, [left, right], calibration.sigma0_px)
    if not result.ok.all():
        return None
    return float(np.sqrt(np.mean(result.residuals_m ** 2))), rig.left.exterior.position


def export_project(project: Project, out: str | Path, opcode: str | None = None) -> int:
    """Write the project's objects that have 3-D vertices to ``out`` (format by suffix, see
    :func:`usvips.io.export.export`); returns how many were written. ``opcode`` (EventMeasure tables):
    default the project file's name."""
    objects, rms, centres, images, cache = [], {}, {}, {}, {}
    pairs = {p["label"]: p for p in project.pairs()}
    for stored in project.objects():
        usable = [v for v in stored.vertices if v.xyz is not None and v.covariance is not None]
        if len(usable) != len(stored.vertices):
            continue
        key = str(stored.id)
        objects.append(MeasuredObject(key, stored.kind, np.array([v.xyz for v in usable]),
                                      np.array([v.covariance for v in usable]), stored.attribute, stored.notes))
        geometry = _ray_geometry(project, stored, cache)
        if geometry is not None:
            rms[key], centres[key] = geometry
        pair = pairs.get(stored.vertices[0].pair) if stored.vertices else None
        if pair is not None:
            frame = "" if pair["frame"] is None else str(pair["frame"])
            images[key] = (Path(pair["left"] or "").name, frame, Path(pair["right"] or "").name, frame)
        video_columns = eventmeasure_frame_columns(project, stored.vertices[0]) if stored.vertices else None
        if video_columns is not None:  # measured on a video: its files, frames, time and period
            images[key] = video_columns
    opcode = opcode if opcode is not None else project.path.stem
    export(objects, out, opcode=opcode, rms_m=rms, camera_centre={o.id: centres.get(o.id, (0.0, 0.0, 0.0))
                                                                  for o in objects}, images=images)
    return len(objects)
