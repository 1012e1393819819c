"""Many objects measured from their picks at once, each exactly as :func:`~usvips.core.measurements.evaluate.
measure_picks` measures it (the same intersection, the same two covariance parts, the same figure function
:func:`~usvips.core.measurements.evaluate.measure`): the calibration's derivatives of every vertex of every
object measured with one calibration are computed in one batch (:func:`~usvips.core.calibration.
uncertainty.intersection_derivatives`; each vertex's row depends on its own pixels alone), and each object's
(3N, 3N) parts are built from its own rows — a project's thousand objects without a thousand traces of the
stepped cameras (the σ check, :mod:`usvips.app.sigma_check`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from usvips.core.calibration.uncertainty import intersection_derivatives
from usvips.core.errors import DegenerateGeometryError, UsvipsError
from usvips.core.measurements.correlated_pointing import correlated_covariances, correlations, kept_where_failed
from usvips.core.measurements.evaluate import Measurement, calibration_marks, measure
from usvips.core.measurements.figures import QualityRules, block_diagonal
from usvips.core.measurements.registry import kind as kind_named
from usvips.core.pointing import per_vertex
from usvips.core.rays import RayStatus
from usvips.core.stereo_calibration import StereoCalibration


def measure_picks_many(kinds: Sequence[str], calibration: StereoCalibration, left: Sequence[np.ndarray],
                       right: Sequence[np.ndarray], station: int | str = 0, frame: str = "object",
                       pointing_sigma_px: Sequence[float | np.ndarray | None] | None = None,
                       rules: QualityRules | None = None,
                       pointing_correlation: Sequence[float | np.ndarray | None] | None = None
                       ) -> list[Measurement | UsvipsError]:
    """Each object (``kinds[i]``, picks ``left[i]``/``right[i]`` (N_i, 2) px, ``pointing_sigma_px[i]`` and
    ``pointing_correlation[i]`` as :func:`measure_picks` takes them) measured with ``calibration`` at
    ``station`` in ``frame``: its :class:`Measurement`, or the :class:`UsvipsError` that measuring it alone
    raises (an object's failure does not stop the others)."""
    count = len(kinds)
    sigmas = list(pointing_sigma_px) if pointing_sigma_px is not None else [None] * count
    linked = list(pointing_correlation) if pointing_correlation is not None else [None] * count
    out: list[Measurement | UsvipsError | None] = [None] * count
    rows, blocks, rhos = [], [], {}
    start = 0
    for i, (kind, one_left, one_right, s, r) in enumerate(zip(kinds, left, right, sigmas, linked, strict=True)):
        one_left = np.asarray(one_left, dtype=np.float64).reshape(-1, 2)
        one_right = np.asarray(one_right, dtype=np.float64).reshape(-1, 2)
        try:
            kind_named(kind).check_count(len(one_left))
            sigma = per_vertex(s, len(one_left))
            rhos[i] = correlations(r, len(one_left))
            if len(one_right) != len(one_left) or not (np.all(np.isfinite(one_left))
                                                       and np.all(np.isfinite(one_right))):
                raise DegenerateGeometryError("its picks are not finite pixel pairs")
        except UsvipsError as error:
            out[i] = error
            continue
        rows.append((i, slice(start, start + len(one_left))))
        blocks.append((one_left, one_right, np.array(sigma)))
        start += len(one_left)
    if not rows:
        return out
    left_all, right_all, sigma_all = (np.concatenate([b[k] for b in blocks]) for k in range(3))
    result, derivatives, parameter_covariance = intersection_derivatives(calibration, left_all, right_all, station,
                                                                         frame, sigma_all)
    camera = calibration.rig(station, frame).left.exterior.position
    marks = calibration_marks(calibration)
    vertex_covariance = _with_correlations(calibration, left_all, right_all, sigma_all, rows, rhos, result,
                                           station, frame)
    for i, where in rows:
        failed = np.flatnonzero(~result.ok[where])
        if failed.size:
            status = RayStatus(int(result.status[where][failed[0]]))
            out[i] = DegenerateGeometryError(f"vertex {int(failed[0])}: {status.reason}")
            continue
        points = result.points[where]
        pointing = block_diagonal(vertex_covariance[where])
        calibration_part = np.zeros_like(pointing)
        if derivatives is not None:
            flat = derivatives[:, where].reshape(len(derivatives), -1)
            calibration_part = flat.T @ parameter_covariance @ flat
        ray_rms = float(np.sqrt(np.mean(result.residuals_m[where] ** 2)))
        range_m = float(np.max(np.linalg.norm(points - camera, axis=1)))
        try:
            out[i] = measure(kinds[i], points, pointing + calibration_part, ray_rms, range_m, rules, True,
                             pointing=pointing, pointing_sigma_px=sigma_all[where].copy(),
                             pointing_origin="default", marks=marks)
            if rhos[i] is not None:
                out[i] = replace(out[i], pointing_correlation=rhos[i])
        except UsvipsError as error:
            out[i] = error
    return out


def _with_correlations(calibration, left, right, sigma, rows, rhos, result, station, frame) -> np.ndarray:
    """The (M, 3, 3) pointing covariances of all objects' vertices: the intersection's, with those of the
    vertices correlated left to right (``rhos``, per object) replaced by
    :func:`~usvips.core.measurements.correlated_pointing.correlated_covariances`, all in one batch."""
    rho = np.zeros(len(left))
    for i, where in rows:
        if rhos[i] is not None:
            rho[where] = rhos[i]
    chosen = np.flatnonzero((rho > 0) & result.ok)
    if not chosen.size:
        return result.covariance
    out = np.array(result.covariance, copy=True)
    out[chosen] = kept_where_failed(correlated_covariances(calibration, left[chosen], right[chosen], sigma[chosen],
                                                           rho[chosen], station, frame), out[chosen])
    return out
