"""Figures of a project's stored objects, for the window, ``usvips measure`` and every export alike.

What the store keeps, and why: each vertex keeps its picks (pixels), the calibration it was measured
with (``calibration_id``) and its pair, besides its own X, Y, Z and 3 × 3 covariance. The figures of an
object are RECOMPUTED from the picks with that stored calibration (:func:`usvips.core.measurements.
measure_picks`), which gives the joint (3N, 3N) covariance of the object's vertices with the correlation
that the common calibration puts between them. We do not store a joint covariance per object: it is
derived data (the picks and the calibration determine it exactly), it would grow with N², and it would
go stale whenever the numbers engineer improves the propagation — recomputing keeps one source of truth.
Only when the calibration is gone or unreadable, or the vertices were measured with different
calibrations, do the stored per-vertex values serve (uncorrelated; ``Measurement.joint`` is False and
the exports say ``per-vertex``).

Reading (:func:`measurement_input`, on the thread that owns the project) is split from computing
(:func:`evaluate`, pure, any thread) so that the window can compute many objects in a worker.

An object measured on several instants (``ProjectStore.add_instant``) is read with its further instants
(``MeasurementInput.instants``) and :func:`evaluate` gives its figures combined over them
(:func:`usvips.core.measurements.instants.combine_measurements`: random effects, the calibration's part
common to the instants kept whole), so the object list, the calculator and every export show the combined
figure; each instant stays inspectable through :func:`instant_measurements`. Instants made by tracking
(stored with their link, ``MeasurementInput.tracked_from``; never read from their notes) carry the pick
they were tracked from, with its error, to every frame: their pointing errors are one error, which
combining them cannot average out — it is kept whole in the combined sigma (``shared_pointing``); only the
tracking noise and the object's own change between instants average out. (An object with tracked and
hand-picked instants is treated so too: conservative for the hand-picked ones.) Instants a model pointed at
on each frame on its own keep whole the share of their pointing errors that the model's measured frame
correlation says (stated in their vertices' sources), and the whole of it when none was measured.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from usvips.app.calibrations import read_calibration
from usvips.app.pair_geometry import pair_geometry
from usvips.app.pointing_settings import pointing_in_use, pointing_with_estimates
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError, UsvipsError
from usvips.core.measurements import (
    Measurement,
    QualityRules,
    calibration_marks,
    intersect_vertices,
    measure,
    measure_picks,
    placement,
)
from usvips.core.measurements.correlated_pointing import with_correlation
from usvips.core.measurements.figures import block_diagonal
from usvips.core.measurements.instants import combine_measurements
from usvips.core.pointing import (
    PointingSigma,
    frame_correlation_of,
    source_from_label,
    vertex_correlation,
    vertex_pointing,
)
from usvips.core.stereo_calibration import StereoCalibration
from usvips.store.interface import ProjectStore
from usvips.store.project import StoredObject, Vertex


@dataclass(frozen=True)
class MeasurementInput:
    """Everything :func:`evaluate` needs, copied out of the project: picks (N, 2) px per side, stored
    X, Y, Z (N, 3) m (NaN where none) and covariances (N, 3, 3) m², and the calibration with the station
    and frame the object's pair measures in (None when there is no single usable calibration)."""

    id: str
    kind: str
    left: np.ndarray
    right: np.ndarray
    xyz: np.ndarray
    covariances: np.ndarray
    calibration: StereoCalibration | None
    station: int | str = 0
    frame: str = "rig"
    attribute: str = ""
    notes: str = ""
    pair: str | None = None
    # where the object (its first instant) was measured ("pair P", "video V frame F"), the calibration id its
    # vertices share (None: none or several), and its further instants when measured on several
    where: str = ""
    calibration_id: int | None = None
    instants: tuple[MeasurementInput, ...] = ()
    # how this further instant was made (``ProjectStore.instant_sources``): the left frame its track started
    # from, None when picked by hand (or when this is the object itself)
    tracked_from: int | None = None
    # the vertices' pointing (usvips.core.pointing.vertex_pointing): sigmas (N, 2) px [left, right], their
    # origin, and the marks a figure from them carries; None: the hand-click default
    pointing_px: np.ndarray | None = None
    pointing_origin: str = "default"
    pointing_marks: tuple[str, ...] = ()
    # each vertex's left-right pointing correlation (N,) (usvips.core.pointing.vertex_correlation); None:
    # independent
    pointing_correlation: np.ndarray | None = None
    # the fraction of the vertices that are a model's keypoints (1: a detection proposal as proposed; less
    # once a reviewer moved some): the model's error on one fish repeats on the frames that see it, so its
    # instants' pointing errors are not independent either; and the frame correlation those vertices state
    model_share: float = 0.0
    frame_correlation: float | None = None


def stored_calibration(project: ProjectStore, calibration_id: int,
                       cache: dict[int, StereoCalibration | None] | None = None) -> StereoCalibration | None:
    """A stored calibration (None when it is gone or unreadable); ``cache`` keeps what was read."""
    cache = {} if cache is None else cache
    if calibration_id not in cache:
        try:
            cache[calibration_id] = read_calibration(project, calibration_id)
        except UsvipsError:
            cache[calibration_id] = None
    return cache[calibration_id]


def place_text(label: str, frame: int | None = None) -> str:
    """A pair or a video's frame for a person: "pair P", or "video 'V', frame F" (the label quoted, so that
    a video labelled "video" does not read "video video frame 5")."""
    return f"pair {label}" if frame is None else f"video '{label}', frame {frame}"


def where_measured(stored: StoredObject) -> str:
    """Where an object was measured, for a person and for jumping there: "video 'V', frame F" (the left
    frame of its first vertex) or "pair P"; "" when its vertices name neither."""
    if not stored.vertices:
        return ""
    vertex = stored.vertices[0]
    if vertex.video is not None:
        return place_text(vertex.video, vertex.frame_left)
    return place_text(vertex.pair) if vertex.pair is not None else ""


def instants_by_object(project: ProjectStore) -> dict[int, list[int]]:
    """Object id → the ids of its further instants, for every object measured on several instants (one
    query: give it to :func:`measurement_input` when reading many objects)."""
    grouped: dict[int, list[int]] = {}
    for instant, whole in project.instant_links().items():
        grouped.setdefault(whole, []).append(instant)
    return grouped


def measurement_input(project: ProjectStore, stored: StoredObject,
                      cache: dict[int, StereoCalibration | None] | None = None,
                      with_instants: bool = True, instants: dict[int, list[int]] | None = None,
                      pointing: dict[tuple[str, str], PointingSigma] | None = None) -> MeasurementInput:
    """Copy what the figures of ``stored`` need out of ``project`` (call on the project's thread), with
    its further instants when it was measured on several (``with_instants``). ``instants``: the project's
    :func:`instants_by_object` when reading many objects (saves one query an object). ``pointing``: the
    project's pointing estimates in use (:func:`usvips.app.pointing_settings.pointing_in_use`, read here
    when None): a vertex whose pointing σ is its source's default takes the estimate in use for its source
    and annotator (its own, else the object's creator; a tracked or auto-matched vertex carries the click
    it follows, so a hand-click estimate) — changing the estimate in use changes every figure here."""
    cache = {} if cache is None else cache
    pointing = pointing_in_use(project) if pointing is None else pointing
    source = _one_instant(project, stored, cache, pointing, stored.creator)
    if with_instants:
        made = project.instant_sources(stored.id) if instants is None else None
        further = list(made) if made is not None else instants.get(stored.id, [])
        if further:
            made = project.instant_sources(stored.id) if made is None else made
            read = {o.id: o for o in project.objects_with_ids(further)}  # (one read, not one an instant)
            instants = tuple(replace(_one_instant(project, read[i] if i in read else project.object(i), cache,
                                                  pointing, stored.creator), tracked_from=made.get(i))
                             for i in further)
            source = replace(source, instants=instants)
    return source


def _one_instant(project: ProjectStore, stored: StoredObject, cache: dict[int, StereoCalibration | None],
                 in_use: dict[tuple[str, str], PointingSigma], creator: str) -> MeasurementInput:
    vertices = stored.vertices
    keys = {(v.calibration_id, v.pair) for v in vertices}
    calibration, station, frame, pair = None, 0, "rig", vertices[0].pair if vertices else None
    if len(keys) == 1 and next(iter(keys))[0] is not None:
        calibration_id, pair = next(iter(keys))
        calibration = stored_calibration(project, calibration_id, cache)
        if calibration is not None:
            station, frame = placement(calibration, pair)
    xyz = np.array([v.xyz if v.xyz is not None else (np.nan,) * 3 for v in vertices], float).reshape(-1, 3)
    covariances = np.array([v.covariance if v.covariance is not None else np.full((3, 3), np.nan)
                            for v in vertices], float).reshape(-1, 3, 3)
    calibration_ids = {v.calibration_id for v in vertices}
    calibration_id = next(iter(calibration_ids)) if len(calibration_ids) == 1 else None
    stated, origins, estimated = pointing_with_estimates(in_use, vertices, creator)
    pointing, origin, marks = vertex_pointing([v.source for v in vertices], stated, origins)
    marks = marks + estimated
    return MeasurementInput(str(stored.id), stored.kind, np.array([[v.xl, v.yl] for v in vertices], float),
                            np.array([[v.xr, v.yr] for v in vertices], float), xyz, covariances, calibration,
                            station, frame, stored.attribute, stored.notes, pair, where_measured(stored),
                            calibration_id, pointing_px=pointing, pointing_origin=origin, pointing_marks=marks,
                            pointing_correlation=vertex_correlation([v.source for v in vertices], pointing),
                            model_share=_model_share(vertices),
                            frame_correlation=_stated_frame_correlation(vertices))


def _model_share(vertices: list[Vertex]) -> float:
    """The fraction of ``vertices`` that are a model's keypoints (0 without vertices)."""
    return sum(_is_keypoint(v.source) for v in vertices) / len(vertices) if vertices else 0.0


def _stated_frame_correlation(vertices: list[Vertex]) -> float | None:
    """The frame correlation the sources of the model's keypoints among ``vertices`` state (the largest,
    should they differ: the cautious one), None when one of them states none or there is none."""
    stated = [frame_correlation_of(v.source) for v in vertices if _is_keypoint(v.source)]
    return None if not stated or any(s is None for s in stated) else max(stated)


def _is_keypoint(label: str) -> bool:
    try:
        return source_from_label(label).kind == "keypoint"
    except InvalidParameterError:
        return False


def evaluate(source: MeasurementInput, rules: QualityRules | None = None) -> Measurement:
    """The object's :class:`Measurement`: from its picks with its calibration (joint covariance), or from
    the stored per-vertex values when that is not possible; combined over its instants when it has
    further ones. Raises :class:`UsvipsError` naming the object (and the instant) when neither gives
    figures or its instants were measured with different calibrations."""
    if not source.instants:
        return _evaluate_one(source, rules)
    everything = (source, *source.instants)
    measured = []
    for instant in everything:
        try:
            measured.append(_evaluate_one(instant, rules))
        except UsvipsError as error:
            raise UsvipsError(f"object {source.id}, instant {instant.id} ({instant.where or 'unknown place'}): "
                              f"{str(error).removeprefix(f'object {instant.id}: ')}") from None
    labels = [f"{i.where or 'object ' + i.id} (object {i.id})" for i in everything]
    try:
        combined = combine_measurements(measured, [_pointing_only(i, m) for i, m in zip(everything, measured,
                                                                                           strict=True)],
                                        labels, [i.calibration_id for i in everything], rules,
                                        **_shared_pointing(source, everything))
    except UsvipsError as error:
        raise UsvipsError(f"object {source.id}: {error}") from None
    return replace(combined, id=source.id, attribute=source.attribute, notes=source.notes)


def evaluate_many(sources: Sequence[MeasurementInput], rules: QualityRules | None = None
                  ) -> list[Measurement | UsvipsError]:
    """:func:`evaluate` of each source — the same :class:`Measurement`, or the :class:`UsvipsError` it
    raises — with the objects measured once from their picks with one calibration (at one station, in one
    frame) intersected together (:func:`usvips.core.measurements.batch.measure_picks_many`: the same
    intersection and covariance parts, a whole batch's calibration derivatives at once; about 14 × less
    time a fish than one at a time). An object with instants, or one the batch cannot measure (its rays do
    not meet, too few vertices: the stored values may still stand), goes through :func:`evaluate` itself."""
    from usvips.core.measurements.batch import measure_picks_many  # not on the window's start

    out: list[Measurement | UsvipsError | None] = [None] * len(sources)
    groups: dict[tuple[int, int | str, str], list[int]] = {}
    for index, source in enumerate(sources):
        if source.calibration is not None and not source.instants:
            groups.setdefault((id(source.calibration), source.station, source.frame), []).append(index)
        else:
            out[index] = _evaluated(source, rules)
    for members in groups.values():
        batch = [sources[i] for i in members]
        head = batch[0]
        measured = measure_picks_many([s.kind for s in batch], head.calibration, [s.left for s in batch],
                                      [s.right for s in batch], head.station, head.frame,
                                      [s.pointing_px for s in batch], rules, [s.pointing_correlation for s in batch])
        camera = np.array(head.calibration.rig(head.station, head.frame).left.exterior.position, float)
        marks = calibration_marks(head.calibration)
        for index, source, one in zip(members, batch, measured, strict=True):
            if isinstance(one, Measurement):  # labelled as measure_picks labels it
                origin = "default" if source.pointing_px is None else source.pointing_origin
                out[index] = replace(one, id=source.id, attribute=source.attribute, notes=source.notes,
                                     pointing_origin=origin, marks=marks + tuple(source.pointing_marks),
                                     camera=camera)
            else:
                out[index] = _evaluated(source, rules)
    return out


def _evaluated(source: MeasurementInput, rules: QualityRules | None) -> Measurement | UsvipsError:
    try:
        return evaluate(source, rules)
    except UsvipsError as error:
        return error


def _shared_pointing(source: MeasurementInput, everything: tuple[MeasurementInput, ...]) -> dict:
    """How the instants' pointing errors are shared (:func:`combine_measurements`' keywords): whole when any
    instant was tracked (one pick carried along) or an instant with a model's keypoints states no measured
    frame correlation; independent when no instant has a model's keypoint (each picked on its own); else by
    the model's measured frame correlation ρ (the largest stated) — per instant ρ × its share of the model's
    keypoints when a reviewer moved some of them (a person's point is independent of the model's other
    frames; the share errs on the cautious side, :func:`usvips.core.measurements.instants.combine_figure`)."""
    if any(i.tracked_from is not None for i in source.instants):
        return {"shared_pointing": True}
    shares = [i.model_share for i in everything]
    if not any(shares):
        return {}
    stated = [i.frame_correlation for i, share in zip(everything, shares, strict=True) if share]
    if any(s is None for s in stated):
        return {"shared_pointing": True}
    rho = max(stated)
    if all(share == 1.0 for share in shares):
        return {"shared_fraction": rho}
    return {"shared_fraction": tuple(rho * share for share in shares)}


def instant_measurements(source: MeasurementInput, rules: QualityRules | None = None) -> list[Measurement]:
    """Each instant of an object measured on its own (the first is the object's own picks), to inspect
    them; an instant without figures is an :class:`UsvipsError` naming it."""
    return [_evaluate_one(instant, rules) for instant in (source, *source.instants)]


def instant_pointing(source: MeasurementInput, rules: QualityRules | None = None) -> list[Measurement]:
    """Each instant of an object measured with its pointing covariance only (the part independent between
    instants, by which :func:`evaluate` weights them); the full measurement where that part cannot be told
    apart. In the order of :func:`instant_measurements`."""
    return [_pointing_only(i, m) for i, m in zip((source, *source.instants), instant_measurements(source, rules),
                                                 strict=True)]


def _pointing_only(source: MeasurementInput, measured: Measurement) -> Measurement:
    """The instant measured with its pointing covariance only (the part independent between instants);
    the measurement itself when the calibration's part cannot be told apart (stored per-vertex values)."""
    if source.calibration is None or not measured.joint:
        return measured
    from usvips.core.calibration.uncertainty import intersect_with_calibration  # not on the window's start

    try:
        result = intersect_with_calibration(source.calibration, source.left, source.right, source.station,
                                            source.frame, include_calibration=False,
                                            pointing_sigma_px=measured.pointing_sigma_px)
        covariance = result.covariance
        if measured.pointing_correlation is not None:
            covariance = with_correlation(source.calibration, source.left, source.right, measured.pointing_sigma_px,
                                          measured.pointing_correlation, block_diagonal(covariance), source.station,
                                          source.frame)
        return measure(source.kind, result.points, covariance, joint=False)
    except UsvipsError:
        return measured


#: why an object stored without 3-D points and without a calibration to measure its picks has no figures
UNMEASURED = ("it has vertices without 3-D coordinates (stored unmeasured — a proposal's notes say why it got no "
              "length; re-pick every point with a calibration active to measure it)")


def _evaluate_one(source: MeasurementInput, rules: QualityRules | None = None) -> Measurement:
    labels = {"id": source.id, "attribute": source.attribute, "notes": source.notes}
    try:
        if source.calibration is not None:
            try:
                return measure_picks(source.kind, source.calibration, source.left, source.right, source.station,
                                     source.frame, rules, **labels, pointing_sigma_px=source.pointing_px,
                                     pointing_origin=source.pointing_origin, marks=source.pointing_marks,
                                     pointing_correlation=source.pointing_correlation)
            except DegenerateGeometryError:
                pass  # rays that no longer meet with this calibration: the stored values still stand
        if not np.all(np.isfinite(source.xyz)) or not np.all(np.isfinite(source.covariances)):
            raise DegenerateGeometryError(UNMEASURED)
        return measure(source.kind, source.xyz, source.covariances, rules=rules, joint=False, **labels)
    except UsvipsError as error:
        raise UsvipsError(f"object {source.id}: {error}") from None


def joint_vertices(source: MeasurementInput) -> tuple[np.ndarray, np.ndarray, bool]:
    """Vertices (N, 3) m and their (3N, 3N) covariance m² of any set of vertices (e.g. two objects'
    together, for the figures between them): joint through the calibration where possible, else the
    stored per-vertex values (the bool says which)."""
    if source.calibration is not None:
        try:
            points, covariance, _, _ = intersect_vertices(source.calibration, source.left, source.right,
                                                          source.station, source.frame, source.pointing_px,
                                                          source.pointing_correlation)
            return points, covariance, True
        except UsvipsError:
            pass  # as in evaluate: the stored values still stand
    covariance = np.zeros((3 * len(source.xyz),) * 2)
    for i, c in enumerate(np.nan_to_num(source.covariances)):
        covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3] = c
    return source.xyz, covariance, False


def measure_stored(project: ProjectStore, stored: StoredObject, rules: QualityRules | None = None,
                   cache: dict[int, StereoCalibration | None] | None = None) -> Measurement:
    """:func:`measurement_input` then :func:`evaluate`."""
    return evaluate(measurement_input(project, stored, cache), rules)


def store_measurements(project: ProjectStore, pair: str, objects: list[tuple[str, str, np.ndarray, str]],
                       rules: QualityRules | None = None, where: str = "",
                       pointing_sigma_px: float | None = None,
                       video_frame: tuple[str, int, int, float] | None = None) -> tuple[list[Measurement], list[int]]:
    """Measure objects — (id, kind, pixels (N, 4) xl yl xr yr, attribute) — with the calibration active
    for ``pair``, placed as the pair measures, and store them as the window does (each vertex with its
    picks, X, Y, Z, 3 × 3 covariance, the calibration and the pair, and its pointing: a hand click with
    ``pointing_sigma_px`` (px, one coordinate) given, or None for the hand-click default; creator
    ``usvips``; the attribute added to the vocabulary): all in one transaction, or nothing when any object
    fails. ``where`` (e.g. the picks file) starts the error messages. ``video_frame``: (video, left frame,
    right frame, time s) when ``pair`` is a video's label and the picks are on that frame pair. Returns the
    measurements and the new objects' ids."""
    geometry = pair_geometry(project, pair)
    if geometry is None:
        raise UsvipsError(f"{project.path}: pair {pair!r} has no active calibration: nothing can be measured")
    calibration, calibration_id, station, frame = (geometry.calibration, geometry.calibration_id,
                                                   geometry.station, geometry.frame)
    stated = None if pointing_sigma_px is None else (float(pointing_sigma_px),) * 2
    measured, rows = [], []
    for object_id, kind, pixels, attribute in objects:
        try:
            m = measure_picks(kind, calibration, pixels[:, :2], pixels[:, 2:], station, frame, rules,
                              id=object_id, attribute=attribute, pointing_sigma_px=pointing_sigma_px,
                              pointing_origin="given")
        except DegenerateGeometryError as error:
            prefix = f"{where}: " if where else ""
            raise DegenerateGeometryError(f"{prefix}object {object_id!r}: {error}") from None
        blocks = [m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3] for i in range(len(m.points))]
        on_frame = dict(zip(("video", "frame_left", "frame_right", "time_s"), video_frame or (), strict=False))
        vertices = [Vertex(*map(float, p), tuple(map(float, xyz)), c, calibration_id, pair, pointing_px=stated,
                           pointing_origin="given" if stated else "default", **on_frame)
                    for p, xyz, c in zip(pixels, m.points, blocks, strict=True)]
        measured.append(m)
        rows.append((m.kind, vertices, attribute, "", ""))  # creator: the store's annotator
    ids = project.add_objects(rows)
    for attribute in sorted({a for *_, a in objects if a}):
        project.add_term(attribute)
    return measured, ids
