"""Intersect an observation file into a points file, chunk by chunk (``usvips intersect``).

The observations (``id,xl,yl,xr,yr``, pixels) are read, intersected with the calibration's covariance
propagated to every point, and written as ``id,X,Y,Z,sX,sY,sZ`` (metres, 6 decimals) a chunk of rows at a
time (:data:`usvips.io.observation_stream.CHUNK_ROWS`), so time grows linearly with the file and memory
stays flat (10⁷ points in a few hundred MB). Every point is intersected on its own, so the rows are the
same however the file is cut into chunks. The points file is written to a temporary file renamed into
place at the end: bad input anywhere (named by its line), a pixel outside its image or, unless failed
points are to be left out, a point that does not intersect, leaves no output file.

The run's dense algebra (the calibration's covariance through each chunk's derivatives: products of
(3n × P) by (P × P) for P of a few tens) runs on one BLAS thread (:mod:`usvips.core.batch_mode`): threaded
OpenBLAS made those products 2-3 times slower in CPU and in wall time on this 2-core machine.

What a chunk goes through is :func:`intersect_chunk` with the options of the run
(:class:`IntersectOptions`); a per-row input such as another pointing precision goes into both.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Iterator
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from usvips.app.ordered_pool import available_cores, ordered_map
from usvips.core.batch_mode import batch_computation
from usvips.core.calibration.uncertainty import intersect_with_calibration
from usvips.core.errors import ConvergenceError, DegenerateGeometryError, InputFileError
from usvips.core.intersection import MISFIT_SIGNIFICANCE, Intersection, misfit_limit, ray_misfit
from usvips.core.observations import StereoObservations
from usvips.core.pointing import HAND_CLICK_SIGMA_PX
from usvips.core.rays import RayStatus
from usvips.core.stereo_calibration import StereoCalibration
from usvips.io.atomic import text_atomic
from usvips.io.observation_stream import CHUNK_ROWS, observation_chunks, observation_header
from usvips.io.tables import outside_image, outside_image_error

#: the points file's columns
POINT_COLUMNS = ("id", "X", "Y", "Z", "sX", "sY", "sZ")


@dataclass(frozen=True)
class IntersectOptions:
    """How to intersect: the calibrated ``station`` (index or pair label; None: each row at the station its
    pair column names, see :func:`row_stations`) and ``frame`` (``object``: the control frame at the
    station; ``rig``: left perspective centre, left axes); whether the sigmas include
    the calibration's own uncertainty (else the pointing precision alone); the picks' pointing sigma
    (px, one image coordinate; the hand-click default of :mod:`usvips.core.pointing` when None — never the
    calibration's sigma0); whether points that do not intersect are left out (listed) instead of failing
    the run; the rows per chunk; the processes that intersect the chunks (None: one per core; 1: this
    process alone)."""

    station: int | str | None = None
    frame: str = "object"
    include_calibration: bool = True
    pointing_sigma_px: float | None = None
    skip_failed: bool = False
    chunk_rows: int = CHUNK_ROWS
    workers: int | None = None


class FailedPointsError(DegenerateGeometryError):
    """Points that do not intersect, with the first one named by its file line; nothing was written."""

    def __init__(self, source: str, line: int | None, point: str, reason: str, failed: int, total: int):
        self.source, self.line, self.point, self.reason = source, line, point, reason
        self.failed, self.total = failed, total
        where = f", line {line}" if line is not None else ""
        super().__init__(f"{source}{where}: point {point!r}: {reason} ({failed} of {total} points failed)")


@dataclass(frozen=True)
class Misfit:
    """A written point whose rays miss more than its pointing sigma explains: its ``point`` id, file
    ``line``, ``misfit`` (chi-square, 1 degree of freedom), the ``limit`` it passed and the RMS of its ray
    residuals (px)."""

    point: str
    line: int | None
    misfit: float
    limit: float
    rms_px: float

    @property
    def text(self) -> str:
        where = f" (line {self.line})" if self.line is not None else ""
        return (f"point {self.point!r}{where}: misfit {self.misfit:.3g} > {self.limit:.3g}, its rays "
                f"{self.rms_px:.2f} px RMS from the point in the images")


@dataclass
class IntersectSummary:
    """What a run wrote: the points read and written, the RMS of the ray residuals of the written points
    (pixels, over every ray), each point left out (id, reason), and the written points whose rays miss more
    than their pointing sigma explains (:func:`usvips.core.intersection.ray_misfit` beyond
    :func:`~usvips.core.intersection.misfit_limit`): how many, and the first in the file as a
    :class:`Misfit`."""

    points: int = 0
    written: int = 0
    residual_square_sum: float = 0.0
    residual_count: int = 0
    skipped: list[tuple[str, str]] = field(default_factory=list)
    misfits: int = 0
    first_misfit: Misfit | None = None
    unplaced: list[str] = field(default_factory=list)

    @property
    def rms_px(self) -> float:
        return float(np.sqrt(self.residual_square_sum / self.residual_count)) if self.residual_count else 0.0


def row_stations(calibration: StereoCalibration, chunk: StereoObservations, station: int | str | None,
                 frame: str, source: str = "") -> np.ndarray:
    """The calibrated station (index) each row of ``chunk`` is intersected at.

    In the rig frame the station does not matter (one relative orientation): station 0 or ``station``.
    In a station's object frame, with ``station`` None, a row whose pair label names a calibrated station
    is intersected there; any other row (a file without a pair column, every label ``"1"``; a pair that is
    no station, such as a measurement pair) at the first station, as before there were pair columns
    (:func:`unplaced_pairs` names those pairs, for the run to say so). With ``station`` given, every row is
    intersected there, but a row whose pair label names ANOTHER calibrated station is an error naming its
    line: its cameras stood elsewhere."""
    labels = calibration.stations
    if frame == "rig" or (station is None and len(labels) == 1):
        return np.full(len(chunk), 0 if station is None else calibration.station_index(station), dtype=np.intp)
    fixed = None if station is None else calibration.station_index(station)
    # one look-up per distinct pair label, not per row (a chunk holds up to 10⁵ rows of a few pairs)
    pairs, rows_of = np.unique(np.asarray(chunk.pairs, dtype=object), return_inverse=True)
    rows_of = rows_of.reshape(-1)
    stations = np.empty(len(pairs), dtype=np.intp)
    elsewhere = []  # (first row, label, its station) of the labels of another calibrated station than the one given
    for p, pair in enumerate(pairs):
        own = labels.index(pair) if pair in labels else None
        if fixed is not None and own is not None and own != fixed:
            elsewhere.append((int(np.argmax(rows_of == p)), pair, own))
        stations[p] = fixed if fixed is not None else (own if own is not None else 0)
    if elsewhere:  # the first such row in the file
        row, pair, own = min(elsewhere)
        raise _row_error(source, chunk, row, f"pair {pair!r} is calibrated station {own} ({pair}), not the station "
                         f"given ({labels[fixed]}): leave the station out to intersect each row at its own pair's "
                         "station")
    return stations[rows_of]


def unplaced_pairs(calibration: StereoCalibration, chunk: StereoObservations, options: IntersectOptions) -> list[str]:
    """The pair labels of ``chunk`` that are no calibrated station but are intersected in one's object frame
    (the first's, :func:`row_stations`): their points are placed as if the rig stood there."""
    if options.frame == "rig" or options.station is not None or len(calibration.stations) == 1:
        return []
    return [pair for pair in dict.fromkeys(chunk.pairs) if pair != "1" and pair not in calibration.stations]


def _row_error(source: str, chunk: StereoObservations, k: int, problem: str) -> InputFileError:
    return InputFileError(source or chunk.source, problem, chunk.lines[k] if chunk.lines else None)


def intersect_chunk(calibration: StereoCalibration, chunk: StereoObservations,
                    options: IntersectOptions) -> Intersection:
    """The intersection of one chunk's conjugate pixels (each point on its own, at its station:
    :func:`row_stations`)."""
    stations = row_stations(calibration, chunk, options.station, options.frame)
    first = int(stations[0]) if len(stations) else 0
    if np.all(stations == first):
        return _intersect_at(calibration, chunk, first, options)
    parts = {int(s): np.flatnonzero(stations == s) for s in np.unique(stations)}
    results = {s: _intersect_at(calibration, chunk.take(rows), s, options) for s, rows in parts.items()}
    return Intersection.gathered([(rows, results[s]) for s, rows in parts.items()], len(chunk))


def _intersect_at(calibration: StereoCalibration, chunk: StereoObservations, station: int,
                  options: IntersectOptions) -> Intersection:
    """The chunk's rows at one station; a row whose pixel the lens distortion cannot undo (the whole
    computation stops there) is found by halving the rows, and marked :attr:`RayStatus.DISTORTION_FOLDS`
    while the others are intersected."""
    try:
        return intersect_with_calibration(calibration, chunk.left, chunk.right, station, options.frame,
                                          include_calibration=options.include_calibration,
                                          pointing_sigma_px=options.pointing_sigma_px)
    except ConvergenceError:
        if len(chunk) == 1:
            return _not_intersected(RayStatus.DISTORTION_FOLDS)
        half = len(chunk) // 2
        parts = [np.arange(half), np.arange(half, len(chunk))]
        return Intersection.gathered([(rows, _intersect_at(calibration, chunk.take(rows), station, options))
                                      for rows in parts], len(chunk))


def _not_intersected(status: RayStatus) -> Intersection:
    """One row that has no intersection, for ``status``'s reason (placeholders of zeros, as every row that
    is not OK holds)."""
    return Intersection(np.zeros((1, 3)), np.zeros((1, 3, 3)), np.zeros((1, 2)), np.zeros((1, 2)),
                        np.array([status], dtype=np.uint8))


@dataclass(frozen=True)
class ChunkOutcome:
    """What one chunk's intersection gives the run: the CSV text of its points that intersect
    (:func:`points_text`), each row's :class:`~usvips.core.rays.RayStatus` and the sum of squares and the
    count of those points' ray residuals (px); how many of those points miss beyond their pointing sigma,
    and the first (its row in the chunk, misfit, limit, RMS px)."""

    text: str
    status: np.ndarray
    residual_square_sum: float
    residual_count: int
    misfits: int = 0
    first_misfit: tuple[int, float, float, float] | None = None


@batch_computation  # one BLAS thread: its products are tall and thin (core/batch_mode.py)
def chunk_outcome(run: tuple[StereoCalibration, IntersectOptions, bool], chunk: StereoObservations) -> ChunkOutcome:
    """One chunk intersected and formatted (``run`` = the calibration, the options and whether the rows
    carry their pair label): the work a worker does (:mod:`usvips.app.ordered_pool`)."""
    calibration, options, with_pair = run
    result = intersect_chunk(calibration, chunk, options)
    residuals = result.residuals_px[result.ok]
    misfit = np.zeros(len(chunk))
    sigma = HAND_CLICK_SIGMA_PX if options.pointing_sigma_px is None else options.pointing_sigma_px
    misfit[result.ok] = ray_misfit(residuals, sigma)
    limit = misfit_limit(result.residuals_px.shape[1], MISFIT_SIGNIFICANCE)
    beyond = np.flatnonzero(misfit > limit)
    first = None
    if beyond.size:
        k = int(beyond[0])
        first = (k, float(misfit[k]), limit, float(np.sqrt(np.mean(result.residuals_px[k] ** 2))))
    return ChunkOutcome(points_text(chunk.ids, result, chunk.pairs if with_pair else None), np.asarray(result.status),
                        float(np.sum(residuals ** 2)), int(residuals.size), int(beyond.size), first)


def point_rows(ids: tuple[str, ...], result: Intersection, pairs: tuple[str, ...] | None = None) -> list[list[str]]:
    """CSV rows ``id, X, Y, Z, sX, sY, sZ`` (metres, 6 decimals; with ``pairs``, the row's pair last) of the
    intersected points, in input order (every number formatted in one pass over a flat list)."""
    ok = np.flatnonzero(result.ok)
    table = np.column_stack([result.points[ok], result.sigmas[ok]])
    texts = [f"{v:.6f}" for v in table.ravel().tolist()]
    last = [[] if pairs is None else [pairs[i]] for i in ok.tolist()]
    return [[ids[i], *texts[6 * row:6 * row + 6], *tail] for row, (i, tail) in enumerate(zip(ok.tolist(), last,
                                                                                             strict=True))]


#: one points row as text: the id, then X, Y, Z, sX, sY, sZ to 6 decimals (as ``f"{v:.6f}"`` writes them)
_ROW = "%s" + ",%.6f" * 6 + "\n"
#: the same with the row's pair label last
_ROW_PAIR = "%s" + ",%.6f" * 6 + ",%s\n"
#: characters that make the csv module quote a field
_QUOTED = re.compile(r'[,"\r\n]')


def points_text(ids: tuple[str, ...], result: Intersection, pairs: tuple[str, ...] | None = None) -> str:
    """The rows of :func:`point_rows` as CSV text (as ``csv.writer`` writes them), formatted by one
    ``%`` over the whole chunk."""
    ok = np.flatnonzero(result.ok)
    chosen = [ids[i] for i in ok.tolist()]
    labels = [] if pairs is None else [pairs[i] for i in ok.tolist()]
    if _QUOTED.search("".join(chosen)) or _QUOTED.search("".join(labels)):  # a field the csv module would quote
        buffer = io.StringIO()
        csv.writer(buffer, lineterminator="\n").writerows(point_rows(ids, result, pairs))
        return buffer.getvalue()
    width = 7 if pairs is None else 8
    flat: list = [None] * (width * len(chosen))
    flat[0::width] = chosen
    for column, values in enumerate((*result.points[ok].T, *result.sigmas[ok].T), start=1):
        flat[column::width] = values.tolist()
    if pairs is not None:
        flat[7::width] = labels
    return ((_ROW if pairs is None else _ROW_PAIR) * len(chosen)) % tuple(flat)


class _OutsideImage:
    """The pixels outside their images met so far: the first per side and how many."""

    def __init__(self, sizes) -> None:
        self.sizes = sizes
        self.first: dict[str, tuple[str, int | None, np.ndarray]] = {}
        self.count = {"left": 0, "right": 0}

    def check(self, chunk: StereoObservations) -> bool:
        """Count the chunk's pixels outside their images; whether there were any."""
        found = False
        for side, pixels, size in (("left", chunk.left, self.sizes[0]), ("right", chunk.right, self.sizes[1])):
            outside = outside_image(pixels, size)
            if outside.any():
                k = int(np.flatnonzero(outside)[0])
                self.first.setdefault(side, (chunk.ids[k], chunk.lines[k] if chunk.lines else None, pixels[k]))
                self.count[side] += int(outside.sum())
                found = True
        return found

    def raise_any(self, source: str) -> None:
        for side, size in zip(("left", "right"), self.sizes, strict=True):
            if side in self.first:
                label, line, pixel = self.first[side]
                raise outside_image_error(source, side, label, line, pixel, size, self.count[side])


def intersect_file(calibration: StereoCalibration, observations: str | Path, out: str | Path,
                   options: IntersectOptions = IntersectOptions()) -> IntersectSummary:
    """Read ``observations``, intersect every point and write the points file ``out`` (see the module
    docstring); raises :class:`~usvips.core.errors.InputFileError` for bad input (file and line) and
    :class:`FailedPointsError` for points that do not intersect unless ``options.skip_failed``."""
    summary = IntersectSummary()
    outside = _OutsideImage(((calibration.left.width, calibration.left.height),
                             (calibration.right.width, calibration.right.height)))
    first_failure: tuple[int | None, str, str] | None = None
    failed = 0
    with_pair = "pair" in (observation_header(observations) or [])  # rows of several pairs: said which
    chunks = _Counted(observations, options, calibration)
    with text_atomic(out) as stream:
        writer = csv.writer(stream, lineterminator="\n")
        writer.writerow(POINT_COLUMNS if not with_pair else (*POINT_COLUMNS, "pair"))  # (pair last: the
        # columns of a file without pairs keep their places)
        with closing(ordered_map(chunk_outcome, (calibration, options, with_pair), _checked(chunks, outside),
                                 _workers(options))) as worked:
            for chunk, outcome in worked:
                if outside.first:
                    continue  # the run fails: the rest of the file is only checked (and its outside pixels counted)
                bad = np.flatnonzero(outcome.status != RayStatus.OK)
                failed += bad.size
                if bad.size and first_failure is None:
                    k = int(bad[0])
                    first_failure = (chunk.lines[k] if chunk.lines else None, chunk.ids[k],
                                     RayStatus(int(outcome.status[k])).reason)
                if failed and not options.skip_failed:
                    continue  # the run fails: the rest is intersected only to count the points that fail
                stream.write(outcome.text)
                summary.written += len(chunk) - bad.size
                summary.residual_square_sum += outcome.residual_square_sum
                summary.residual_count += outcome.residual_count
                summary.misfits += outcome.misfits
                if outcome.first_misfit is not None and summary.first_misfit is None:
                    k, misfit, limit, rms = outcome.first_misfit
                    summary.first_misfit = Misfit(chunk.ids[k], chunk.lines[k] if chunk.lines else None, misfit,
                                                  limit, rms)
                summary.skipped.extend((chunk.ids[i], RayStatus(int(outcome.status[i])).reason)
                                       for i in bad.tolist())
        summary.points = chunks.rows
        summary.unplaced = list(chunks.unplaced)
        outside.raise_any(str(observations))
        if failed and not options.skip_failed:
            line, point, reason = first_failure
            raise FailedPointsError(str(observations), line, point, reason, failed, summary.points)
    return summary


class _Counted:
    """The observation file's chunks, counting the rows read, each row's station checked as it is read
    (:func:`row_stations`: a row of another station's pair is named by its line, as bad input is)."""

    def __init__(self, observations: str | Path, options: IntersectOptions, calibration: StereoCalibration) -> None:
        self.chunks = observation_chunks(observations, rows=options.chunk_rows)
        self.source, self.options, self.calibration = str(observations), options, calibration
        self.rows = 0
        self.unplaced: dict[str, None] = {}

    def __iter__(self) -> Iterator[StereoObservations]:
        for chunk in self.chunks:
            row_stations(self.calibration, chunk, self.options.station, self.options.frame, self.source)
            self.unplaced.update(dict.fromkeys(unplaced_pairs(self.calibration, chunk, self.options)))
            self.rows += len(chunk)
            yield chunk


def _checked(chunks: _Counted, outside: _OutsideImage) -> Iterator[StereoObservations]:
    """The chunks to intersect, in order, each checked for pixels outside their images as it is read; from
    the first such pixel on the rest of the file is only read (its outside pixels counted)."""
    for chunk in chunks:
        if not outside.check(chunk) and not outside.first:
            yield chunk


def _workers(options: IntersectOptions) -> int:
    return available_cores() if options.workers is None else options.workers
