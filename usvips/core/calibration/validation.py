"""Validation of a calibration as a user needs it: views held out, then measured with the calibration.

A share of the views (chosen spread over the set, seeded: :func:`holdout_views`) is left out; the rig
is calibrated on the rest; then, for the held-out views and beside them for the fitted ones:

* the reprojection RMS (pixels, per coordinate): a held-out view's pose is resected with the calibrated
  rig held fixed (interior, housing and relative orientation: only the six numbers of the left camera's
  pose are fitted, the right camera follows rigidly), so its residuals show how well the calibration
  predicts images it never saw; the fitted views' figure is the adjustment's own;
* the error of known target distances (adjacent points, and the diagonal: the two points of each view
  farthest apart on the target) intersected with the calibration, in metres, by range bins (the
  distance of the pair's midpoint from the left perspective centre), so that a user sees how the error
  grows with range;
* whether the calibration's stated uncertainty holds on what it never saw (:func:`held_out_view`): the mean
  squared normalised error (NEES) of the held-out reprojections (residuals over sigma0, per degree of
  freedom) and of the held-out known distances (error over the sigma the calibration gives the length:
  the corners' pointing at sigma0 and the calibration's own covariance, correlated between the two
  corners), with their 95 % sampling intervals; where they depart from 1 beyond them, the calibration's
  sigma0 and covariance are scaled by variance components estimated from the held-out views, and the
  calibration and its report say so (:mod:`.honesty`).

For in-air boards :func:`opencv_stereo` solves the same fitted views with OpenCV's ``stereoCalibrate``
(its default five-term distortion) so that its focal lengths, baseline and RMS can stand beside ours.

Conventions: pixels x right, y down, origin at the centre of the top-left pixel; metres; the rig frame
is the left camera's (x right, y up, looking along −z).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import cv2
import numpy as np

from usvips.core.adjustment import GROSS
from usvips.core.calibration.honesty import HeldOutView, Honesty, apply_honesty, variance_components
from usvips.core.calibration.planar import PlaneFrame, resect_views
from usvips.core.camera import EXTERIOR_PARAMETERS, Exterior
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError, UsvipsError
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.stereo_calibration import StereoCalibration

#: Range bins of the distance figures (the fitted and held-out views share them).
RANGE_BINS = 3

#: Views the calibration keeps at least, whatever the share held out.
MIN_FITTED = 3


def holdout_views(labels: tuple[str, ...] | list[str], share: float, seed: int = 0) -> tuple[str, ...]:
    """The views to hold out: round(share · n) of them (at least one), evenly spread over the set in its
    order (so that a sequence filmed at changing distances is sampled across), with a seeded offset."""
    labels = list(labels)
    if not 0.0 < share < 1.0:
        raise InvalidParameterError("holdout", f"must be between 0 and 1, got {share}",
                                    label="the share of views held out")
    count = max(1, int(round(share * len(labels))))
    if len(labels) - count < MIN_FITTED:
        raise DegenerateGeometryError(
            f"holding out {count} of {len(labels)} views leaves {len(labels) - count} to calibrate from (at least "
            f"{MIN_FITTED} needed): film more views or hold out a smaller share")
    offset = np.random.default_rng(seed).uniform(0.0, 1.0)
    index = np.floor((np.arange(count) + offset) * len(labels) / count).astype(int)
    return tuple(labels[i] for i in np.unique(np.clip(index, 0, len(labels) - 1)))


@dataclass
class DistanceBin:
    """Known-distance errors of pairs whose midpoints lie ``low``-``high`` m from the left camera:
    ``count`` pairs, RMS and mean error (estimated − true, metres), RMS relative error (dimensionless)."""

    low: float
    high: float
    count: int
    rms_m: float
    mean_m: float
    rms_relative: float

    def as_dict(self) -> dict:
        """JSON-able: an empty bin's figures are None."""
        return {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in self.__dict__.items()}


@dataclass
class ViewFigures:
    """The figures of one set of views: their labels, reprojection RMS (px, per coordinate; per view too),
    and the known-distance errors by range bin (adjacent points and diagonals separately)."""

    views: tuple[str, ...]
    rms_px: float
    rms_px_by_view: dict[str, float]
    adjacent: list[DistanceBin]
    diagonal: list[DistanceBin]

    def as_dict(self) -> dict:
        return {"views": list(self.views), "rms_px": self.rms_px, "rms_px_by_view": self.rms_px_by_view,
                "adjacent": [b.as_dict() for b in self.adjacent], "diagonal": [b.as_dict() for b in self.diagonal]}


@dataclass
class Validation:
    """Held-out views against fitted ones (module docstring); ``opencv``: OpenCV's solution of the fitted
    views beside ours (in-air boards), or None; ``honesty``: the NEES figures and the variance scale
    applied (:class:`Honesty`), or None when no held-out distance could be measured."""

    held_out: ViewFigures
    fitted: ViewFigures
    result: object  # the CalibrationResult of the fitted views
    opencv: dict | None = None
    ours: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    honesty: Honesty | None = None

    def as_dict(self) -> dict:
        return {"held_out": self.held_out.as_dict(), "fitted": self.fitted.as_dict(), "ours": self.ours,
                "opencv": self.opencv, "notes": list(self.notes),
                "honesty": self.honesty.as_dict() if self.honesty is not None else None}

    def lines(self) -> list[str]:
        """The validation as a user reads it (one figure a line)."""
        out = [f"validation: {len(self.fitted.views)} views fitted, {len(self.held_out.views)} held out "
               f"({', '.join(self.held_out.views)})",
               f"  reprojection RMS: fitted {self.fitted.rms_px:.3f} px, held out {self.held_out.rms_px:.3f} px "
               "(held-out poses resected with the rig held fixed)"]
        for name in ("adjacent", "diagonal"):
            for fitted, held in zip(getattr(self.fitted, name), getattr(self.held_out, name), strict=True):
                out.append(f"  {name} distances at {fitted.low:.2f}-{fitted.high:.2f} m: fitted "
                           f"{_bin_text(fitted)}; held out {_bin_text(held)}")
        if self.opencv:
            o, u = self.opencv, self.ours
            out.append(f"  OpenCV stereoCalibrate on the fitted views: f {o['f_l']:.2f} / {o['f_r']:.2f} px, baseline "
                       f"{o['baseline_m'] * 1000:.2f} mm, RMS {o['rms_px']:.3f} px; ours: f {u['f_l']:.2f} / "
                       f"{u['f_r']:.2f} px, baseline {u['baseline_m'] * 1000:.2f} mm, RMS {u['rms_px']:.3f} px")
        if self.honesty is not None:
            out += self.honesty.lines()
        out += [f"  {note}" for note in self.notes]
        return out


def _bin_text(b: DistanceBin) -> str:
    if not b.count:
        return "none"
    return (f"{b.count} pair{'' if b.count == 1 else 's'}, RMS {b.rms_m * 1000:.2f} mm ({100 * b.rms_relative:.2f} %), "
            f"mean {b.mean_m * 1000:+.2f} mm")


# ------------------------------------------------------------------------------------------ resection
def resect_with_rig(calibration: StereoCalibration, control: ControlPoints, view: StereoObservations
                    ) -> tuple[Exterior, np.ndarray]:
    """The left camera's pose (object frame of ``control``) of one view with the calibrated rig held
    fixed, and the view's residuals (observed − computed, pixels; (N, 4): left x, y, right x, y)."""
    from scipy.optimize import least_squares  # deferred: scipy.optimize is slow to import

    xyz = control.xyz[control.index_of(list(view.ids), "observation")]
    observed = np.hstack([view.left, view.right])
    label = view.pairs[0]
    start = resect_views(control, view, calibration.left.interior, "l", minimum_views=1)[label]
    rig = calibration.rig(0, frame="rig")

    def residual(vector: np.ndarray) -> np.ndarray:
        try:
            moved = rig.at_pose(Exterior(*vector))
            left, right = moved.left.project(xyz), moved.right.project(xyz)
        except UsvipsError:
            return np.full(observed.size, 1e3)
        computed = np.hstack([left.pixels, right.pixels])
        bad = ~np.isfinite(computed) | np.repeat(np.column_stack([left.status != 0, right.status != 0]), 2, axis=1)
        return np.where(bad, 1e3, observed - computed).reshape(-1)

    vector = np.array([getattr(start, p) for p in EXTERIOR_PARAMETERS])
    solution = least_squares(residual, vector, x_scale=np.array([0.01, 0.01, 0.01, 0.01, 0.01, 0.01]),
                             method="trf")
    pose = Exterior(*solution.x)
    return pose, residual(solution.x).reshape(-1, 4)


# ------------------------------------------------------------------------------------------ distances
def known_pairs(control: ControlPoints, ids: tuple[str, ...]) -> tuple[list[tuple[int, int]], tuple[int, int]]:
    """Among the points ``ids`` (rows of one view), the adjacent pairs (control distance within 1 % of the
    target's smallest spacing) and the diagonal (the two farthest apart); row indices into ``ids``."""
    xyz = control.xyz[control.index_of(list(ids), "observation")]
    distance = np.linalg.norm(xyz[:, None, :] - xyz[None, :, :], axis=2)
    spacing = _spacing(control)
    i, j = np.nonzero(np.triu(distance <= 1.01 * spacing, 1))
    far = np.unravel_index(int(np.argmax(distance)), distance.shape)
    return list(zip(i.tolist(), j.tolist(), strict=True)), (int(far[0]), int(far[1]))


def _spacing(control: ControlPoints) -> float:
    xyz = control.xyz
    distance = np.linalg.norm(xyz[:, None, :] - xyz[None, :, :], axis=2)
    np.fill_diagonal(distance, np.inf)
    return float(np.min(distance))


def _distance_errors(calibration: StereoCalibration, control: ControlPoints, view: StereoObservations
                     ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per kind (``adjacent``, ``diagonal``): the range (m) of each pair's midpoint from the left camera,
    its error (estimated − true length, m) and its true length (m), for the view's pairs both of whose
    points intersect."""
    from usvips.core.calibration.uncertainty import intersect_with_calibration

    result = intersect_with_calibration(calibration, view.left, view.right, 0, "rig", include_calibration=False)
    xyz = control.xyz[control.index_of(list(view.ids), "observation")]
    adjacent, diagonal = known_pairs(control, view.ids)

    def figures(pairs):
        ranges, errors, lengths = [], [], []
        for a, b in pairs:
            if not (result.ok[a] and result.ok[b]):
                continue
            true = float(np.linalg.norm(xyz[a] - xyz[b]))
            errors.append(float(np.linalg.norm(result.points[a] - result.points[b])) - true)
            lengths.append(true)
            ranges.append(float(np.linalg.norm(0.5 * (result.points[a] + result.points[b]))))
        return np.array(ranges), np.array(errors), np.array(lengths)

    return {"adjacent": figures(adjacent), "diagonal": figures([diagonal])}


def _bins(ranges: np.ndarray, errors: np.ndarray, lengths: np.ndarray, edges: np.ndarray) -> list[DistanceBin]:
    """The errors binned by range (``edges``, metres; the last bin includes its upper edge)."""
    out = []
    for k in range(len(edges) - 1):
        inside = (ranges >= edges[k]) & ((ranges < edges[k + 1]) | (k == len(edges) - 2) & (ranges <= edges[k + 1]))
        e, length = errors[inside], lengths[inside]
        out.append(DistanceBin(float(edges[k]), float(edges[k + 1]), int(inside.sum()),
                               float(np.sqrt(np.mean(e**2))) if e.size else float("nan"),
                               float(np.mean(e)) if e.size else float("nan"),
                               float(np.sqrt(np.mean((e / length) ** 2))) if e.size else float("nan")))
    return out


# ------------------------------------------------------------------------------------------ honesty
def held_out_view(calibration: StereoCalibration, control: ControlPoints, view: StereoObservations,
                  residuals: np.ndarray) -> HeldOutView:
    """One held-out view's figures for :func:`~usvips.core.calibration.honesty.variance_components`:
    Σ v² / sigma0² of its reprojection ``residuals`` ((N, 4) from :func:`resect_with_rig`) and its degrees
    of freedom; each known distance's error (metres) and the pointing and calibration parts of its variance
    (m²; intersected in the rig frame, the calibration's covariance correlating the two corners). A corner
    reprojected more than :data:`~usvips.core.adjustment.GROSS` sigma0 off (a detector's blunder, as the
    adjustment sets aside) is left out of both."""
    from usvips.core.calibration.uncertainty import intersect_with_calibration, joint_covariance

    sigma = calibration.sigma0_px
    keep = np.all(np.abs(residuals) < GROSS * sigma, axis=1)
    dof = 4 * int(keep.sum()) - 6
    gross = int((~keep).sum())
    empty = np.zeros(0)
    if dof <= 0:
        return HeldOutView(0.0, 0, empty, empty, empty, gross)
    rows = np.flatnonzero(keep)
    left, right = view.left[rows], view.right[rows]
    result, covariance = joint_covariance(calibration, left, right, 0, "rig")
    pointing = intersect_with_calibration(calibration, left, right, 0, "rig", include_calibration=False).covariance
    ids = tuple(view.ids[r] for r in rows)
    xyz = control.xyz[control.index_of(list(ids), "observation")]
    adjacent, diagonal = known_pairs(control, ids)
    errors, points, parts = [], [], []
    for a, b in adjacent + [diagonal]:
        if a == b or not (result.ok[a] and result.ok[b]):
            continue
        difference = result.points[a] - result.points[b]
        length = float(np.linalg.norm(difference))
        unit = difference / max(length, 1e-300)
        index = np.r_[3 * a:3 * a + 3, 3 * b:3 * b + 3]
        gradient = np.concatenate([unit, -unit])
        total = float(gradient @ covariance[np.ix_(index, index)] @ gradient)
        own = float(unit @ pointing[a] @ unit + unit @ pointing[b] @ unit)
        if total > 0 and own > 0:
            errors.append(length - float(np.linalg.norm(xyz[a] - xyz[b])))
            points.append(own)
            parts.append(max(total - own, 0.0))
    normalised = residuals[keep] / sigma
    return HeldOutView(float(np.sum(normalised**2)), dof, np.array(errors), np.array(points), np.array(parts), gross,
                       float(np.sum(normalised**4)), int(normalised.size))


# ------------------------------------------------------------------------------------------ OpenCV
def opencv_stereo(control: ControlPoints, observations: StereoObservations,
                  image_size: tuple[int, int]) -> dict:
    """OpenCV's ``stereoCalibrate`` of the same views of a planar target (each camera first by
    ``calibrateCamera``, then jointly; OpenCV's default k1, k2, p1, p2, k3): focal lengths fx (f) and fy
    per camera (px), the baseline (metres) and the RMS per coordinate (px; OpenCV's own figure is per
    point, √2 times larger)."""
    frame = PlaneFrame.of(control.xyz[control.index_of(list(dict.fromkeys(observations.ids)), "observation")])
    objects, lefts, rights = [], [], []
    for label in observations.pair_labels:
        view = observations.pair(label)
        plane = frame.coordinates(control.xyz[control.index_of(list(view.ids), "observation")])
        plane[:, 2] = 0.0
        objects.append(plane.astype(np.float32))
        lefts.append(view.left.astype(np.float32))
        rights.append(view.right.astype(np.float32))
    size = (int(image_size[0]), int(image_size[1]))
    _, k1, d1, _, _ = cv2.calibrateCamera(objects, lefts, size, None, None)
    _, k2, d2, _, _ = cv2.calibrateCamera(objects, rights, size, None, None)
    error, k1, d1, k2, d2, _, translation, *_ = cv2.stereoCalibrate(
        objects, lefts, rights, k1, d1, k2, d2, size, flags=cv2.CALIB_USE_INTRINSIC_GUESS,
        criteria=(cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-9))
    return {"f_l": float(k1[0, 0]), "fy_l": float(k1[1, 1]), "f_r": float(k2[0, 0]), "fy_r": float(k2[1, 1]),
            "baseline_m": float(np.linalg.norm(translation)), "rms_px": float(error / np.sqrt(2.0)),
            "rms_px_per_point": float(error)}


def _ours(calibration: StereoCalibration, rms_px: float) -> dict:
    rig = calibration.rig(0, frame="rig")
    return {"f_l": rig.left.interior.f, "fy_l": rig.left.interior.f / rig.left.interior.sy,
            "f_r": rig.right.interior.f, "fy_r": rig.right.interior.f / rig.right.interior.sy,
            "baseline_m": float(np.linalg.norm(rig.right.exterior.position)), "rms_px": rms_px}


# ------------------------------------------------------------------------------------------ the whole
def validate(control: ControlPoints, observations: StereoObservations, share: float,
             fit: Callable[[StereoObservations], object], seed: int = 0, compare_opencv: bool = False,
             image_size: tuple[int | None, int | None] = (None, None)) -> Validation:
    """Hold out ``share`` of the views (:func:`holdout_views`), ``fit`` the rest (a function of the
    observations returning a CalibrationResult, e.g. a closure over :func:`calibrate_air`), and measure
    both sets (module docstring). ``compare_opencv``: put OpenCV's solution of the fitted views beside
    ours (in-air planar targets; needs ``image_size``)."""
    held = set(holdout_views(observations.pair_labels, share, seed))
    fitted_rows = np.flatnonzero([p not in held for p in observations.pairs])
    held_rows = np.flatnonzero([p in held for p in observations.pairs])
    fitted_obs, held_obs = observations.take(fitted_rows), observations.take(held_rows)
    result = fit(fitted_obs)
    calibration = result.calibration
    report = result.report
    fitted_rms = {}
    for row in report.used_residuals():
        fitted_rms.setdefault(row.station, []).extend([row.vx ** 2, row.vy ** 2])
    held_rms: dict[str, list[float]] = {}
    held_residuals = []
    for label in held_obs.pair_labels:
        _, residuals = resect_with_rig(calibration, control, held_obs.pair(label))
        held_rms[label] = (residuals.reshape(-1) ** 2).tolist()
        held_residuals.append(residuals)
    figures = {}
    for name, obs in (("fitted", fitted_obs), ("held", held_obs)):
        parts = [_distance_errors(calibration, control, obs.pair(label)) for label in obs.pair_labels]
        figures[name] = {kind: tuple(np.concatenate([p[kind][k] for p in parts]) for k in range(3))
                         for kind in ("adjacent", "diagonal")}
    every = np.concatenate([f[kind][0] for f in figures.values() for kind in ("adjacent", "diagonal")])
    if not every.size:
        raise DegenerateGeometryError("no known distance of the target could be intersected in any view")
    edges = np.linspace(every.min(), every.max() + 1e-9, RANGE_BINS + 1)

    def view_figures(name: str, views: tuple[str, ...], squares: dict[str, list[float]]) -> ViewFigures:
        adjacent, diagonal = (_bins(*figures[name][kind], edges) for kind in ("adjacent", "diagonal"))
        flat = np.concatenate([np.asarray(v, float) for v in squares.values()]) if squares else np.array([np.nan])
        return ViewFigures(tuple(views), float(np.sqrt(np.mean(flat))),
                           {k: float(np.sqrt(np.mean(v))) for k, v in squares.items()}, adjacent, diagonal)

    validation = Validation(view_figures("held", held_obs.pair_labels, held_rms),
                            view_figures("fitted", fitted_obs.pair_labels, fitted_rms), result)
    validation.ours = _ours(calibration, validation.fitted.rms_px)
    validation.honesty = variance_components(
        [held_out_view(calibration, control, held_obs.pair(label), residuals)
         for label, residuals in zip(held_obs.pair_labels, held_residuals, strict=True)], seed)
    if validation.honesty is not None:
        apply_honesty(result, validation.honesty)
    if compare_opencv:
        if not (image_size[0] and image_size[1]):
            raise InvalidParameterError("image_size", "OpenCV's comparison needs it", label="image size")
        validation.opencv = opencv_stereo(control, fitted_obs, (int(image_size[0]), int(image_size[1])))
    return validation
