"""The double-read report of a survey: the objects two annotators (readers) measured on the same videos
and image pairs, paired and compared (:mod:`usvips.core.double_reading`), for the command line
(``usvips project double-read``) and the window's dialog alike.

Reading goes through the :class:`~usvips.store.interface.ProjectStore` protocol only (any backend). Each
object's figure and its σ come from :func:`usvips.app.project_figures.evaluate` — the one function the
object list, the calculator and every export use (an object measured on several instants is compared
with its combined figure). A reader is an object's creator (``StoredObject.creator``); its identification
is its observation record's (family, genus, species) — all '' when it has none — compared level by level
(:func:`usvips.core.double_reading.taxa_agree`: a coarser identification agrees with a finer one when
they agree on the levels both give), shown as ``Genus species`` or, identified to family only, the family;
the instant is its first vertex's time on
a video (seconds) and left frame (the tolerance is given in exactly one of them), none on an image pair
(the pair is the instant); its place is the mean of its
vertices (metres, in the frame its video or pair measures in). An object on a video whose first vertex
has neither a time nor a frame has no instant: it is left unmatched (never paired with an object at the
start of the video), its report row says why (column ``note``) and the summary lists it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from usvips.app.object_instants import survey_objects
from usvips.app.pointing_settings import pointing_in_use
from usvips.app.project_figures import MeasurementInput, evaluate, instants_by_object, measurement_input
from usvips.core.double_reading import DoubleReading, ReaderObjects, check_parameters, compare_readers
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.measurements import Measurement, QualityRules
from usvips.store.interface import ProjectStore
from usvips.store.records import StoredObject

#: the report's table columns (CSV and dialog alike); lengths and σ in metres
COLUMNS = ["row", "object_a", "object_b", "source", "time_s", "species", "kind", "value_a", "sigma_a", "value_b",
           "sigma_b", "difference", "combined_sigma", "normalised", "note"]

#: the note of an unmatched object that has no instant (on a video, with neither time nor frame)
NO_INSTANT = "no time or frame on its video: not paired"

#: what a row of the report is, in the order the report lists them
ROW_KINDS = ("disagreement", "species conflict", "unmatched A", "unmatched B", "agreement")


class ReportCancelled(UsvipsError):
    """The report's computation stopped because it was cancelled (``cancelled()`` turned true)."""


@dataclass(frozen=True)
class ReaderRead:
    """One reader's objects as compared (:class:`ReaderObjects`), where each was measured (a person's
    words, e.g. "video V frame F"), the objects that have no figure (one line each: "object N: why") and
    those left unmatched because they have no instant (one line each)."""

    name: str
    objects: ReaderObjects
    where: list[str]
    skipped: list[str]
    no_instant: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class DoubleReadReport:
    """Two readers' objects compared: the readers, the parameters (``tolerance_s`` s or, when it is None,
    ``tolerance_frames`` frames; ``gate_m`` m, ``k``) and the comparison
    (:class:`~usvips.core.double_reading.DoubleReading`)."""

    a: ReaderRead
    b: ReaderRead
    tolerance_s: float | None
    gate_m: float
    k: float
    comparison: DoubleReading
    tolerance_frames: float | None = None

    @property
    def tolerance(self) -> str:
        """The time tolerance in words: '0.5 s' or '3 frames'."""
        if self.tolerance_s is not None:
            return f"{self.tolerance_s:g} s"
        return f"{self.tolerance_frames:g} frame" + ("" if self.tolerance_frames == 1 else "s")

    def rows(self) -> list[dict]:
        """The report's table (:data:`COLUMNS`): the flagged pairs, the species conflicts, each reader's
        unmatched objects, then the pairs that agree; object ids are the stored ids (None: no object)."""
        c, a, b = self.comparison, self.a.objects, self.b.objects
        out = []
        for (i, j), difference, sigma, flagged in zip(c.pairs, c.difference, c.combined_sigma, c.flagged, strict=True):
            normalised = difference / sigma if sigma > 0 else (0.0 if difference == 0 else math.inf)
            out.append(_row("disagreement" if flagged else "agreement", a, i, b, j, difference, sigma, normalised))
        for i, j in c.species_conflicts:
            out.append(_row("species conflict", a, i, b, j))
        out += [_row("unmatched A", a, i, None, None) for i in c.unmatched_a]
        out += [_row("unmatched B", None, None, b, j) for j in c.unmatched_b]
        return sorted(out, key=lambda r: ROW_KINDS.index(r["row"]))

    def summary(self) -> list[str]:
        """The agreement statistics as lines for a person (lengths in mm)."""
        s, c = self.comparison.agreement, self.comparison

        def mm(value: float, sign: str = "+") -> str:
            return "—" if math.isnan(value) else f"{1000 * value:{sign}.1f} mm"

        def share(value: float) -> str:
            return "—" if math.isnan(value) else f"{100 * value:.1f} %"

        return [
            f"readers: A {self.a.name!r} ({_count(s.n_a, 'object')}), B {self.b.name!r} ({_count(s.n_b, 'object')}); "
            f"tolerance {self.tolerance}, gate {self.gate_m:g} m, k {self.k:g}",
            f"matched: {_count(s.n_matched, 'pair')} ({share(s.matched_share)} of the objects); unmatched: "
            f"{len(c.unmatched_a)} of A, {len(c.unmatched_b)} of B",
            f"differences A − B: mean {mm(s.mean_difference)}, SD {mm(s.sd_difference, '')}; Bland–Altman limits of "
            f"agreement {mm(s.limits[0])} … {mm(s.limits[1])}",
            f"within combined σ: {share(s.share_within_sigma)}; within {self.k:g} σ: {share(s.share_within_k)}; "
            f"flagged: {int(np.sum(c.flagged))}; RMS of normalised differences: "
            + ("—" if math.isnan(s.rms_normalised) else f"{s.rms_normalised:.2f}"),
            f"species agreement: {share(s.species_agreement)} of {_count(s.n_species_compared, 'object')} "
            f"paired on place and time ({len(c.species_conflicts)} conflicts)",
        ] + [f"no figure, left out: {line}" for line in self.a.skipped + self.b.skipped] + [
            f"no instant, left unmatched: {line}" for line in [*self.a.no_instant, *self.b.no_instant]]


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}" + ("" if n == 1 else "s")


def _row(what: str, a: ReaderObjects | None, i: int | None, b: ReaderObjects | None, j: int | None,
         difference: float | None = None, sigma: float | None = None, normalised: float | None = None) -> dict:
    first = a if a is not None else b
    k = i if a is not None else j
    return {"row": what, "object_a": None if a is None else int(a.ids[i]),
            "object_b": None if b is None else int(b.ids[j]), "source": first.source[k],
            "time_s": None if math.isnan(first.time_s[k]) else float(first.time_s[k]),
            "species": (first.species[k] if what != "species conflict"
                        else f"{a.species[i] or 'unidentified'} / {b.species[j] or 'unidentified'}"),
            "kind": first.kind[k], "value_a": None if a is None else float(a.value[i]),
            "sigma_a": None if a is None else float(a.sigma[i]), "value_b": None if b is None else float(b.value[j]),
            "sigma_b": None if b is None else float(b.sigma[j]),
            "difference": None if difference is None else float(difference),
            "combined_sigma": None if sigma is None else float(sigma),
            "normalised": None if normalised is None else float(normalised),
            "note": "" if first.instant_known[k] else NO_INSTANT}


def annotators(project: ProjectStore) -> dict[str, int]:
    """Every creator of the survey's objects → how many objects they made (each object once)."""
    counts: dict[str, int] = {}
    for stored in survey_objects(project):
        counts[stored.creator] = counts.get(stored.creator, 0) + 1
    return dict(sorted(counts.items()))


def _source_and_time(project: ProjectStore, stored: StoredObject,
                     fps: dict[str, float]) -> tuple[str, float, float, bool]:
    """(where: "video V" / "pair P", time s, left frame index, whether the instant is known) of an object's
    first vertex; time and frame NaN on an image pair (the frame NaN too when a video's vertex has none).
    A video's vertex with neither a time nor a frame has no instant (time and frame NaN, known False)."""
    vertex = stored.vertices[0]
    if vertex.video is not None:
        frame = math.nan if vertex.frame_left is None else float(vertex.frame_left)
        if vertex.time_s is not None:
            return f"video {vertex.video}", float(vertex.time_s), frame, True
        if vertex.frame_left is None:
            return f"video {vertex.video}", math.nan, math.nan, False
        if vertex.video not in fps:
            fps[vertex.video] = float(project.video(vertex.video).fps)
        return f"video {vertex.video}", float(vertex.frame_left) / fps[vertex.video], frame, True
    return (f"pair {vertex.pair}" if vertex.pair is not None else ""), math.nan, math.nan, True


@dataclass(frozen=True)
class ReaderInput:
    """What one reader's comparison needs, copied out of the project (:func:`read_inputs`): per object its
    :class:`~usvips.app.project_figures.MeasurementInput`, species shown and identification (``taxa``:
    family, genus, species), source ("video V" / "pair P") and
    instant (s, and the video's left frame; NaN on an image pair; ``known`` False where a video's object
    has neither)."""

    name: str
    sources: tuple[MeasurementInput, ...]
    species: tuple[str, ...]
    places: tuple[str, ...]
    times: tuple[float, ...]
    frames: tuple[float, ...] = ()
    known: tuple[bool, ...] = ()
    taxa: tuple[tuple[str, str, str], ...] = ()


@dataclass(frozen=True)
class DoubleReadInput:
    """Both readers' :class:`ReaderInput` (read on the project's thread; :func:`compute` runs anywhere)."""

    a: ReaderInput
    b: ReaderInput


def _reader_input(project: ProjectStore, reader: str, objects: list[StoredObject]) -> ReaderInput:
    records = project.records()
    instants = instants_by_object(project)
    pointing = pointing_in_use(project)  # read once, not once an object
    cache: dict = {}
    fps: dict[str, float] = {}
    sources, species, places, times, frames, known, taxa = [], [], [], [], [], [], []
    for stored in objects:
        if stored.creator != reader or not stored.vertices:
            continue
        sources.append(measurement_input(project, stored, cache, instants=instants, pointing=pointing))
        record = records.get(stored.id)
        taxon = ("", "", "") if record is None else (record.family, record.genus, record.species)
        taxa.append(taxon)
        species.append(f"{taxon[1]} {taxon[2]}".strip() or taxon[0])
        place, time_s, frame, instant_known = _source_and_time(project, stored, fps)
        places.append(place)
        times.append(time_s)
        frames.append(frame)
        known.append(instant_known)
    return ReaderInput(reader, tuple(sources), tuple(species), tuple(places), tuple(times), tuple(frames),
                       tuple(known), tuple(taxa))


def read_inputs(project: ProjectStore, reader_a: str, reader_b: str) -> DoubleReadInput:
    """Copy what the comparison of annotators ``reader_a`` and ``reader_b`` needs out of ``project`` (call
    on the project's thread). A reader who made no object of the survey, or the same reader twice, is an
    error naming them (and who did make objects)."""
    if reader_a == reader_b:
        raise InvalidParameterError("readers", f"give two different annotators, got {reader_a!r} twice",
                                    label="readers")
    objects = survey_objects(project)
    present = {o.creator for o in objects}
    for name in (reader_a, reader_b):
        if name not in present:
            known = ", ".join(repr(n) for n in sorted(present)) or "nobody: it has no objects"
            raise InvalidParameterError("readers", f"{project.path}: annotator {name!r} measured no object of "
                                        f"this survey (objects were measured by {known})", label="readers")
    return DoubleReadInput(_reader_input(project, reader_a, objects), _reader_input(project, reader_b, objects))


def _reader_read(reader: ReaderInput, rules: QualityRules | None, step: Callable[[], None]) -> ReaderRead:
    columns: dict[str, list] = {name: [] for name in ("ids", "source", "kind", "species", "time_s", "midpoint",
                                                       "value", "sigma", "frame", "instant_known", "taxon")}
    where, skipped, no_instant = [], [], []
    frames = reader.frames or (math.nan,) * len(reader.sources)
    known = reader.known or (True,) * len(reader.sources)
    taxa = reader.taxa or tuple(("", "", name) for name in reader.species)
    for source, species, place, time_s, frame, instant_known, taxon in zip(
            reader.sources, reader.species, reader.places, reader.times, frames, known, taxa, strict=True):
        step()
        try:
            measured: Measurement = evaluate(source, rules)
        except UsvipsError as error:
            skipped.append(f"{reader.name}: {error}")
            continue
        for name, value in (("ids", int(source.id)), ("source", place), ("kind", measured.kind),
                            ("species", species), ("time_s", time_s),
                            ("midpoint", np.mean(measured.points, axis=0)), ("value", measured.main.value),
                            ("sigma", measured.main.sigma), ("frame", frame), ("instant_known", instant_known),
                            ("taxon", taxon)):
            columns[name].append(value)
        where.append(source.where)
        if not instant_known:
            no_instant.append(f"{reader.name}: object {source.id} ({place}): its vertex has neither a time nor "
                              "a frame")
    objects = ReaderObjects(**columns) if columns["ids"] else ReaderObjects.empty()
    return ReaderRead(reader.name, objects, where, skipped, no_instant)


def compute(inputs: DoubleReadInput, tolerance_s: float | None = 0.5, gate_m: float = 0.3, k: float = 2.0,
            rules: QualityRules | None = None, progress: Callable[[float], None] | None = None,
            cancelled: Callable[[], bool] | None = None, tolerance_frames: float | None = None) -> DoubleReadReport:
    """The report (pure; any thread): each object's figure and σ by :func:`evaluate`, then
    :func:`~usvips.core.double_reading.compare_readers`. The time tolerance in exactly one of seconds
    (``tolerance_s``) or frames (``tolerance_frames``, with ``tolerance_s=None``). ``progress`` gets the
    fraction done; when ``cancelled()`` turns true the work stops with :class:`ReportCancelled`."""
    check_parameters(tolerance_s, gate_m, k, tolerance_frames)  # before the long part
    total = max(1, len(inputs.a.sources) + len(inputs.b.sources))
    done = [0]

    def step() -> None:
        if cancelled is not None and cancelled():
            raise ReportCancelled(f"the double-read report was cancelled after {done[0]} of {total} objects")
        done[0] += 1
        if progress is not None and done[0] % 20 == 0:
            progress(done[0] / total)

    a = _reader_read(inputs.a, rules, step)
    b = _reader_read(inputs.b, rules, step)
    report = DoubleReadReport(a, b, None if tolerance_s is None else float(tolerance_s), float(gate_m), float(k),
                              compare_readers(a.objects, b.objects, tolerance_s, gate_m, k, tolerance_frames),
                              None if tolerance_frames is None else float(tolerance_frames))
    if progress is not None:
        progress(1.0)
    return report


def double_read(project: ProjectStore, reader_a: str, reader_b: str, tolerance_s: float | None = 0.5,
                gate_m: float = 0.3, k: float = 2.0, rules: QualityRules | None = None,
                tolerance_frames: float | None = None) -> DoubleReadReport:
    """:func:`read_inputs` then :func:`compute`: compare the objects of annotators ``reader_a`` and
    ``reader_b`` (see the module docstring); the time tolerance in seconds, or in frames with
    ``tolerance_s=None``."""
    check_parameters(tolerance_s, gate_m, k, tolerance_frames)
    return compute(read_inputs(project, reader_a, reader_b), tolerance_s, gate_m, k, rules,
                   tolerance_frames=tolerance_frames)
