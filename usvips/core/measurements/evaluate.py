"""The one function that computes every figure of a measured object and its sigma, and checks it
against the quality rules — for the window, the geo-calculator, ``usvips measure`` and every export.

:func:`measure_picks` is the path from the picks: every vertex is intersected with the calibration, and
the figures' sigmas come from the JOINT (3N, 3N) covariance of the object's vertices: the pointing part,
from each vertex's own pointing sigma (pixels, one coordinate, :mod:`usvips.core.pointing`; never the
calibration's σ0), and the calibration's part, from its parameter covariance, which is common to all
vertices and correlates them (a length partly cancels it). Each figure carries its sigma's breakdown into
those two shares, from the same Jacobian (``Figure.sigma_pointing``, ``Figure.sigma_calibration``), and the
measurement carries the facts a reader of the sigma must see (:attr:`Measurement.marks`: an assumed σ0, a
calibration without covariance, a default pointing sigma for vertices of unknown source).
:func:`measure` takes vertices and a covariance directly (e.g. stored values when the calibration an
object was measured with is no longer available: then the vertices are uncorrelated, ``joint=False``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from usvips.core.errors import DegenerateGeometryError
from usvips.core.measurements.combined_figure import CombinedFigure
from usvips.core.measurements.correlated_pointing import correlations, with_correlation
from usvips.core.measurements.figures import Figure, QualityRules, full_covariance
from usvips.core.measurements.registry import kind as kind_named
from usvips.core.pointing import per_vertex
from usvips.core.rays import RayStatus
from usvips.core.stereo_calibration import StereoCalibration


@dataclass(frozen=True)
class Measurement:
    """A measured object: kind, vertices (N, 3) m, their joint covariance (3N, 3N) m², its figures
    (in the kind's order; :attr:`main` is the main one) and the quality rules it breaks; the
    ray-intersection RMS (m) over its vertices and the largest range (m) from the left camera when
    known; ``joint``: whether the covariance carries the correlation between the vertices (False for
    stored per-vertex covariances); ``combined``: when the object was measured on several instants, its
    figures combined over them (:mod:`usvips.core.measurements.instants`) — ``figures`` are then those
    combined figures, ``points`` the first instant's. ``pointing_correlation``: each vertex's left–right
    pointing correlation (N,) when any was correlated (:mod:`usvips.core.measurements.correlated_pointing`),
    else None."""

    kind: str
    points: np.ndarray
    covariance: np.ndarray
    figures: tuple[Figure, ...]
    failures: tuple[str, ...] = ()
    ray_rms_m: float | None = None
    range_m: float | None = None
    joint: bool = True
    id: str = ""
    attribute: str = ""
    notes: str = ""
    combined: tuple[CombinedFigure, ...] = ()
    pointing_sigma_px: np.ndarray | None = None
    pointing_origin: str = ""
    marks: tuple[str, ...] = ()
    camera: np.ndarray | None = None
    pointing_correlation: np.ndarray | None = None

    @property
    def instant_count(self) -> int:
        """How many instants the figures combine (1: measured once)."""
        return self.combined[0].count if self.combined else 1

    @property
    def main(self) -> Figure:
        """The kind's main figure (length, area, diameter; Z of a point)."""
        return self.figure(kind_named(self.kind).main_name())

    def figure(self, name: str) -> Figure:
        for figure in self.figures:
            if figure.name == name:
                return figure
        raise KeyError(name)

    @property
    def vertex_sigmas(self) -> np.ndarray:
        """(N, 3) standard deviations (m) of the vertices' X, Y, Z."""
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None)).reshape(-1, 3)


def measure(kind: str, points: np.ndarray, covariance: np.ndarray, ray_rms_m: float | None = None,
            range_m: float | None = None, rules: QualityRules | None = None, joint: bool | None = None,
            id: str = "", attribute: str = "", notes: str = "", *, pointing: np.ndarray | None = None,
            pointing_sigma_px: np.ndarray | None = None, pointing_origin: str = "",
            marks: tuple[str, ...] = ()) -> Measurement:
    """Figures with sigmas and quality of an object of ``kind`` (a registered name) from its vertices
    (N, 3) m and their covariance, (3N, 3N) joint or (N, 3, 3) per vertex (m²). ``pointing``: the pointing
    part of that covariance (same shapes; the rest is the calibration's) — then every figure carries its
    sigma's breakdown. ``pointing_sigma_px``, ``pointing_origin``, ``marks``: see :class:`Measurement`.
    Degenerate geometry raises :class:`DegenerateGeometryError`, an unknown kind :class:`UnknownKindError`."""
    measurement_kind = kind_named(kind)
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not np.all(np.isfinite(points)):
        raise DegenerateGeometryError(f"a {kind} with vertices without 3-D coordinates")
    given = np.asarray(covariance, dtype=np.float64)
    full = full_covariance(points, given)
    figures = measurement_kind.figures(points, full, pointing)
    rules = rules or QualityRules()
    main = next(f for f in figures if f.name == measurement_kind.main_name())
    failures = rules.check(main, ray_rms_m, range_m, relative=measurement_kind.relative_rule)
    return Measurement(measurement_kind.name, points, full, figures, tuple(failures), ray_rms_m, range_m,
                       given.ndim == 2 if joint is None else joint, id, attribute, notes,
                       pointing_sigma_px=pointing_sigma_px, pointing_origin=pointing_origin, marks=tuple(marks))


def calibration_marks(calibration: StereoCalibration) -> tuple[str, ...]:
    """What every figure measured with ``calibration`` must say of its sigma, one sentence each: a σ0 the
    calibration's file did not state (``assumed``), and a calibration without a parameter covariance (its
    figures' sigmas hold the pointing share only)."""
    marks = []
    if calibration.sigma0_origin == "assumed":
        marks.append(f"calibration sigma0 {calibration.sigma0_px:.2f} px assumed (its file states no residual)")
    if calibration.covariance is None:
        marks.append("calibration without covariance: sigma holds pointing only")
    return tuple(marks)


def placement(calibration: StereoCalibration, label: str | None) -> tuple[int | str, str]:
    """Where a pair measures: (station, frame) — the object frame at its station when the pair is a
    calibrated station, otherwise the rig frame (origin at the left camera's perspective centre)."""
    if label is not None and label in calibration.stations:
        return label, "object"
    return 0, "rig"


def intersect_vertices(calibration: StereoCalibration, left: np.ndarray, right: np.ndarray,
                       station: int | str = 0, frame: str = "object",
                       pointing_sigma_px: float | np.ndarray | None = None,
                       pointing_correlation: float | np.ndarray | None = None
                       ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Vertices (N, 3) m of picks (N, 2) px with their JOINT covariance (3N, 3N) m², the ray-intersection
    RMS (m) over them and their largest range (m) from the left camera. ``pointing_sigma_px``: the picks'
    pointing sigmas (px, one image coordinate) — a scalar, (N,) per vertex or (N, 2) [left, right] per
    vertex; None: the documented default of an unspecified source (a hand click,
    :data:`usvips.core.pointing.HAND_CLICK_SIGMA_PX`), never the calibration's σ0. A vertex whose rays fail
    is a :class:`DegenerateGeometryError` naming the vertex (0-based) and why. ``pointing_correlation``: the
    correlation of each vertex's left and right pointing errors (a scalar or (N,); None or 0: independent),
    :mod:`usvips.core.measurements.correlated_pointing`."""
    points, pointing, calibration_part, ray_rms, range_m = vertex_covariance_parts(
        calibration, left, right, station, frame, pointing_sigma_px, pointing_correlation)
    return points, pointing + calibration_part, ray_rms, range_m


def vertex_covariance_parts(calibration: StereoCalibration, left: np.ndarray, right: np.ndarray,
                            station: int | str = 0, frame: str = "object",
                            pointing_sigma_px: float | np.ndarray | None = None,
                            pointing_correlation: float | np.ndarray | None = None
                            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
    """:func:`intersect_vertices` with the joint covariance in its two parts (3N, 3N) m² that add up to
    it: vertices, pointing part, calibration part, ray RMS (m), range (m)."""
    # here, not at the top: the calibration's model and uncertainty are not needed to read kinds, rules or a
    # calibration's placement (the window's start)
    from usvips.core.calibration.uncertainty import covariance_parts

    left = np.asarray(left, dtype=np.float64).reshape(-1, 2)
    right = np.asarray(right, dtype=np.float64).reshape(-1, 2)
    sigma = per_vertex(pointing_sigma_px, len(left))
    rho = correlations(pointing_correlation, len(left))
    result, pointing, calibration_part = covariance_parts(calibration, left, right, station, frame, sigma)
    failed = np.flatnonzero(~result.ok)
    if failed.size:
        raise DegenerateGeometryError(f"vertex {int(failed[0])}: {RayStatus(int(result.status[failed[0]])).reason}")
    pointing = with_correlation(calibration, left, right, sigma, rho, pointing, station, frame)
    camera = calibration.rig(station, frame).left.exterior.position
    ray_rms = float(np.sqrt(np.mean(result.residuals_m ** 2)))
    range_m = float(np.max(np.linalg.norm(result.points - camera, axis=1)))
    return result.points, pointing, calibration_part, ray_rms, range_m


def measure_picks(kind: str, calibration: StereoCalibration, left: np.ndarray, right: np.ndarray,
                  station: int | str = 0, frame: str = "object", rules: QualityRules | None = None,
                  id: str = "", attribute: str = "", notes: str = "",
                  pointing_sigma_px: float | np.ndarray | None = None, pointing_origin: str = "default",
                  marks: tuple[str, ...] = (), pointing_correlation: float | np.ndarray | None = None) -> Measurement:
    """Intersect the picks (N, 2) px of an object's vertices with ``calibration`` at ``station`` in
    ``frame`` (:func:`intersect_vertices`, ``pointing_sigma_px`` as there) and :func:`measure` it from
    their joint covariance, every figure with its sigma's breakdown (pointing share, calibration share).
    ``pointing_origin``: where the pointing sigmas come from (``default`` when None is given); ``marks``:
    further facts about the sigmas, after the calibration's own (:func:`calibration_marks`).
    ``pointing_correlation``: as :func:`intersect_vertices` takes it (None: independent left and right)."""
    measurement_kind = kind_named(kind)
    count = len(np.asarray(left).reshape(-1, 2))
    measurement_kind.check_count(count)
    sigma = per_vertex(pointing_sigma_px, count)
    points, pointing, calibration_part, ray_rms, range_m = vertex_covariance_parts(
        calibration, left, right, station, frame, sigma, pointing_correlation)
    measured = measure(measurement_kind.name, points, pointing + calibration_part, ray_rms, range_m, rules, True, id,
                       attribute, notes, pointing=pointing, pointing_sigma_px=np.array(sigma),
                       pointing_origin="default" if pointing_sigma_px is None else pointing_origin,
                       marks=calibration_marks(calibration) + tuple(marks))
    rho = correlations(pointing_correlation, count)
    return replace(measured, camera=np.array(calibration.rig(station, frame).left.exterior.position, float),
                   pointing_correlation=rho)
