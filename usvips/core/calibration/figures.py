"""A calibration's figures for a person: each camera's focal length, principal point, pixel aspect and
distortion, the rig's baseline, and the housing's values — each with its unit and its a-posteriori σ.

The one place these figures and their σ are computed: the wizard's parameter table and the printable
report (:mod:`usvips.io.calibration_report`) both list :func:`parameter_table`, and phase 1's check that
the baseline is established uses :func:`baseline_sigma`.

Conventions: pixels for the interior (x right, y down); distortion terms dimensionless (normalised image
coordinates, :mod:`usvips.core.interior`); metres for lengths; σ is None for a parameter held fixed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from usvips.core import housing as housings
from usvips.core.stereo_calibration import StereoCalibration

#: the interior's figures in the order a person reads them: symbol → (label, unit)
INTERIOR_FIGURES = {"f": ("focal length", "px"), "xp": ("principal point x", "px"),
                    "yp": ("principal point y", "px"), "sy": ("pixel aspect (y/x)", ""),
                    "k1": ("radial distortion K1", ""), "k2": ("radial distortion K2", ""),
                    "k3": ("radial distortion K3", ""), "p1": ("decentring P1", ""),
                    "p2": ("decentring P2", "")}
SIDES = (("l", "left"), ("r", "right"))


@dataclass(frozen=True)
class ParameterFigure:
    """One figure: ``group`` (``left camera``, ``right camera``, ``rig``, ``left housing`` …), the
    parameter's ``name`` in the calibration (``f_l``; ``baseline`` for the derived length), a ``label``
    in words, ``value`` and ``sigma`` (None when held fixed) in ``unit``, and ``status`` (free, prior,
    fixed, derived)."""

    group: str
    name: str
    label: str
    value: float
    sigma: float | None
    unit: str
    status: str

    def text(self) -> str:
        """``value ± σ unit`` (or ``value unit (fixed)``), with as many digits as σ asks for."""
        digits = _digits(self.value, self.sigma)
        unit = f" {self.unit}" if self.unit else ""
        if self.sigma is None:
            return f"{self.value:.{digits}f}{unit} ({self.status})"
        return f"{self.value:.{digits}f} ± {self.sigma:.{digits}f}{unit}"


def _digits(value: float, sigma: float | None) -> int:
    """Decimals that show two significant digits of σ (of the value when σ is None or zero), 0 to 8."""
    reference = sigma if sigma else abs(value) * 1e-4 if value else 1e-4
    return int(np.clip(1 - np.floor(np.log10(abs(reference))), 0, 8))


def baseline_sigma(base: np.ndarray, names: Sequence[str], covariance: np.ndarray) -> float:
    """The σ (m) of the baseline's length |``base``| (the right perspective centre less the left, m) from
    the covariance (``names``, matrix) of the first station's two centres (X0_l … Z0_r); 0 when the
    covariance holds none of them (centres fixed)."""
    centres = [f"{p}_{side}" for side, _ in SIDES for p in ("X0", "Y0", "Z0")]
    index = {n: i for i, n in enumerate(names)}
    unit = np.asarray(base, float) / max(float(np.linalg.norm(base)), 1e-300)
    gradient = np.concatenate([-unit, unit])
    present = [k for k, n in enumerate(centres) if n in index]
    if not present:
        return 0.0
    rows = [index[centres[k]] for k in present]
    g = gradient[present]
    return float(np.sqrt(max(g @ np.asarray(covariance, float)[np.ix_(rows, rows)] @ g, 0.0)))


def _rig_baseline(calibration: StereoCalibration) -> ParameterFigure:
    rig = calibration.rig(0)
    base = rig.right.exterior.position - rig.left.exterior.position
    sigma = None
    if calibration.covariance is not None:
        names, matrix = calibration.covariance
        sigma = baseline_sigma(base, names, matrix) or None
    return ParameterFigure("rig", "baseline", "baseline (between the perspective centres)",
                           float(np.linalg.norm(base)), sigma, "m", "derived")


def parameter_table(calibration: StereoCalibration) -> list[ParameterFigure]:
    """The figures a person checks first, in reading order: per camera the interior (focal length,
    principal point, aspect, distortion), the rig's baseline, then the housing's values (none in air) as
    the calibration names them: per camera (``d_l``) or shared by both (``t``, ``n2``). Each from the
    calibration's parameters (value, σ, status); a parameter the calibration does not list is taken from
    its cameras, as fixed."""
    figures: list[ParameterFigure] = []
    for letter, side in SIDES:
        camera = getattr(calibration, side)
        for symbol, (label, unit) in INTERIOR_FIGURES.items():
            figures.append(_figure(calibration, f"{side} camera", f"{symbol}_{letter}", label, unit,
                                   float(getattr(camera.interior, symbol))))
    figures.append(_rig_baseline(calibration))
    kind = calibration.left.housing.kind
    if kind != "air":
        cls = housings.kind(kind)
        groups = {"l": ("left housing", "left"), "r": ("right housing", "right")}
        for name in cls.calibration_names:
            symbol, _, letter = name.rpartition("_") if name[-2:] in ("_l", "_r") else (name, "", "")
            spec = cls.spec(symbol)
            group, side = groups.get(letter, ("housing (both cameras)", "left"))
            value = getattr(calibration, side).housing.to_values().get(symbol, np.nan)
            figures.append(_figure(calibration, group, name, spec.meaning, spec.unit, float(value)))
    return figures


def _figure(calibration: StereoCalibration, group: str, name: str, label: str, unit: str,
            fallback: float) -> ParameterFigure:
    estimate = calibration.parameters.get(name)
    if estimate is None:
        return ParameterFigure(group, name, label, fallback, None, unit, "fixed")
    return ParameterFigure(group, name, label, float(estimate.value), estimate.sigma, unit, estimate.status)
