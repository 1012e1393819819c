"""Exporting a project's measured objects (objects CSV, vertices CSV, GeoJSON through the project's
georeference, PLY, EventMeasure-style tables and _Metadata.csv for CheckEM): joins the store (the
objects, their picks and calibrations) to io's writers, for the command line and the workstation alike.

The figures are those of :func:`usvips.app.project_figures.measure_stored` — recomputed from the picks with
the calibration each object was measured with, so with the joint covariance of its vertices — the very
function the window's object list and geo-calculator call: an exported s_length, the EventMeasure
Precision and the window's sigma are one number.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from usvips.app.calibrations import require_readable_calibrations
from usvips.app.object_instants import survey_objects
from usvips.app.pointing_settings import pointing_in_use
from usvips.app.project_figures import evaluate, instants_by_object, measurement_input
from usvips.app.video_project import eventmeasure_frame_columns
from usvips.core.deployment import Deployment, Georeference
from usvips.core.errors import UsvipsError
from usvips.core.measurements import Measurement, QualityRules
from usvips.core.observation_record import ObservationRecord
from usvips.io.export import eventmeasure_paths, export
from usvips.store.interface import ProjectStore


def checkem_samples(project: ProjectStore) -> list[tuple[Deployment, str]]:
    """The samples of CheckEM's ``_Metadata.csv``: each stored deployment, once per period of the videos it
    covers (a video's own deployment covers that video, the project's covers the rest), or once without a
    period when they have none."""
    stored = project.deployments()
    videos = [v.label for v in project.videos()]
    samples = []
    for scope, deployment in stored.items():
        covered = [scope] if scope else [v for v in videos if v not in stored]
        periods = [name for video in covered for name, _, _ in project.periods(video)]
        samples += [(deployment, period) for period in dict.fromkeys(periods)] or [(deployment, "")]
    return samples


def export_targets(out: str | Path) -> list[Path]:
    """The files :func:`export_project` writes for ``out``: ``out`` itself, or the EventMeasure-style set
    for a name ending ``.em.txt``."""
    out = Path(out)
    return list(eventmeasure_paths(out).values()) if out.name.endswith(".em.txt") else [out]


@dataclass(frozen=True)
class ExportContent:
    """What an export of a project's objects writes, read and computed once: the objects' measurements
    (their figures), and by object id their OpCode, camera centre (m), image columns, observation record
    and place columns; the samples of CheckEM's ``_Metadata.csv`` (:func:`checkem_samples`) and the
    project's georeference."""

    objects: list[Measurement]
    opcodes: dict[str, str]
    centres: dict[str, tuple]
    images: dict[str, tuple]
    records: dict[str, ObservationRecord]
    places: dict[str, tuple]
    samples: list[tuple[Deployment, str]]
    georeference: Georeference | None

    def eventmeasure(self) -> dict:
        """The keywords of :func:`usvips.io.export.eventmeasure_tables` for these objects."""
        return {"opcode": self.opcodes, "camera_centre": self.centres, "images": self.images,
                "records": self.records, "samples": self.samples}


def collect_export(project: ProjectStore, geographic: bool = False, opcode: str | None = None,
                   rules: QualityRules | None = None, skipped: list[str] | None = None,
                   creator: str | None = None) -> ExportContent:
    """Read and measure what :func:`export_project` writes (see there); ``geographic``: only the objects
    measured in the object frame (for GeoJSON); ``creator``: only the objects this annotator made. A
    stored calibration that cannot be read is an error (:func:`usvips.app.calibrations.
    require_readable_calibrations`)."""
    require_readable_calibrations(project)
    objects, centres, images, cache, opcodes, where = [], {}, {}, {}, {}, {}
    fallback = opcode if opcode is not None else project.path.stem
    deployments = project.deployments()
    pairs = {p.label: p for p in project.pairs()}
    instants = instants_by_object(project)
    pointing = pointing_in_use(project)  # read once, not once an object
    for stored in survey_objects(project):  # an object on several instants: once, its figures combined
        if creator is not None and stored.creator != creator:
            continue
        source = measurement_input(project, stored, cache, instants=instants, pointing=pointing)
        try:
            measurement = evaluate(source, rules)
        except UsvipsError as error:
            if skipped is not None:
                skipped.append(str(error))
            continue
        if geographic and source.calibration is not None and source.frame == "rig":  # camera-relative metres
            if skipped is not None:
                skipped.append(f"object {stored.id}: measured in the rig frame of pair {source.pair!r} (not a "
                               "calibrated station), so it has no place on the Earth and no height; it is in the "
                               "CSV exports")
            continue
        objects.append(measurement)
        where[measurement.id] = source.pair or ""
        video = (stored.vertices[0].video if stored.vertices else None) or ""
        deployment = deployments.get(video, deployments.get(""))  # as Project.deployment(video), read once
        opcodes[measurement.id] = deployment.opcode if deployment is not None else fallback
        if source.calibration is not None:
            centres[measurement.id] = source.calibration.rig(source.station, source.frame).left.exterior.position
        pair = pairs.get(source.pair)
        if pair is not None:
            frame = "" if pair.frame is None else str(pair.frame)
            images[measurement.id] = (Path(pair.left or "").name, frame, Path(pair.right or "").name, frame)
        video_columns = eventmeasure_frame_columns(project, stored.vertices[0]) if stored.vertices else None
        if video_columns is not None:  # measured on a video: its files, frames, time and period
            images[measurement.id] = video_columns
    records = {o.id: record for o in objects if (record := project.record(int(o.id))) is not None}
    places = {o.id: (where[o.id], *images.get(o.id, ("", "", "", ""))[:4],
                     images[o.id][4] if len(images.get(o.id, ())) > 4 else "") for o in objects}
    return ExportContent(objects, opcodes, {o.id: centres.get(o.id, (0.0, 0.0, 0.0)) for o in objects}, images,
                         records, places, checkem_samples(project), project.georeference())


def export_project(project: ProjectStore, out: str | Path, opcode: str | None = None,
                   rules: QualityRules | None = None, skipped: list[str] | None = None) -> int:
    """Write the project's objects that have figures to ``out`` (format by suffix, see
    :func:`usvips.io.export.export`); returns how many were written. Objects without figures (no 3-D
    vertices) are left out and named in ``skipped`` ("object N: why") when a list is given. ``opcode``
    (EventMeasure tables): the OpCode of objects whose video (or project) has no stored deployment
    (:meth:`Project.deployment`); default the project file's name. The set of tables includes CheckEM's
    ``_Metadata.csv`` (:func:`checkem_samples`). ``rules``: the quality rules (defaults). An object
    measured on several instants is one row with its combined figures and the number of instants; its
    image columns are those of its first instant. GeoJSON holds only objects measured in the object frame
    (on a calibrated station), the frame the georeference places on the Earth; the others are named in
    ``skipped``."""
    geographic = Path(out).suffix.lower() in (".geojson", ".json")  # WGS 84 through the object frame's georeference
    content = collect_export(project, geographic, opcode, rules, skipped)
    export(content.objects, out, georeference=content.georeference, places=content.places, **content.eventmeasure())
    return len(content.objects)
