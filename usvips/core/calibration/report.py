"""A calibration's adjustment report as named fields: the figures of the fit, each parameter's estimate,
each observation's residual, the suspects and the notes (built by
:func:`usvips.core.calibration.phases.build_report`).

Pixels are image pixels (px); a residual is observed minus adjusted (px); w-test values and redundancy
numbers have no unit. The report is frozen: a step that changes it (held-out views scaling the sigmas,
:func:`usvips.core.calibration.honesty.apply_honesty`) makes a new one with :func:`dataclasses.replace`.
Its file form (``usvips calibrate --report``) is written and read in one place,
:mod:`usvips.io.adjustment_report`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from usvips.core.adjustment import Suspect
from usvips.core.calibration.control_blunders import ControlBlunder
from usvips.core.stereo_calibration import ParameterEstimate


@dataclass(frozen=True)
class ResidualRow:
    """One image point's residual: control point ``id`` seen on ``side`` (``l``/``r``) at ``station`` (the
    pair's label); ``vx``, ``vy`` residuals (px; None when no ray of the adjusted camera reaches the point);
    ``wx``, ``wy`` their w-test values; ``redundancy_x``, ``redundancy_y`` their redundancy numbers (0–1);
    ``used``: whether the adjustment used both coordinates (a set-aside row's residual is a prediction);
    ``note``: why a row has no residual ("" when it has one)."""

    id: str
    side: str
    station: str
    vx: float | None
    vy: float | None
    wx: float
    wy: float
    redundancy_x: float
    redundancy_y: float
    used: bool
    note: str = ""

    @property
    def set_aside(self) -> bool:
        """Whether the adjustment set this observation aside (its residual is a prediction)."""
        return not self.used


@dataclass(frozen=True)
class Correlation:
    """Two parameters ``a`` and ``b`` whose estimates correlate by ``r`` (−1…1, beyond ±0.95 in a report)."""

    a: str
    b: str
    r: float


@dataclass(frozen=True)
class BoundHit:
    """A parameter that ended on a physical bound: its name, which ``bound`` (``lower``/``upper``) and the
    bound's ``value`` (the parameter's unit)."""

    parameter: str
    bound: str
    value: float


@dataclass(frozen=True)
class CalibrationReport:
    """The report of one calibration's adjustment.

    ``phase`` (``air``, ``water`` …), ``housing`` (its kind), ``stations`` (pair labels); ``converged``,
    ``reason`` (why it stopped), ``iterations``; ``sigma0_px`` (the a-posteriori σ of one image coordinate,
    px), ``rms_px`` (RMS residual over the kept observations, px; ``rms_px_all`` over all, None when some
    have none), ``set_aside`` (image coordinates not used), ``redundancy`` (degrees of freedom);
    ``parameters`` by name (value, σ and status: :class:`ParameterEstimate`); ``correlations`` over 0.95;
    ``condition_number`` of the normal equations; ``weak_directions`` (each a tuple of (parameter, weight)
    of a poorly determined combination); ``control_blunders`` (control points demoted to tie points),
    ``suspects`` (observations data snooping rejects), ``on_bound``; ``model_doubt`` (a sentence, or None);
    ``global_test`` and ``estimation``: the adjustment's own records
    (:class:`usvips.core.adjustment.Adjustment`); ``residuals`` one row per image point; ``notes`` for a
    person. After held-out views scaled the sigmas: ``sigma0_px_estimated`` (the fit's own σ0, px) and
    ``variance_scale`` (the factors and why); None before.
    """

    phase: str
    housing: str
    stations: tuple[str, ...]
    converged: bool
    reason: str
    iterations: int
    sigma0_px: float
    rms_px: float
    rms_px_all: float | None
    set_aside: int
    redundancy: int
    parameters: Mapping[str, ParameterEstimate]
    correlations: tuple[Correlation, ...]
    condition_number: float
    weak_directions: tuple[tuple[tuple[str, float], ...], ...]
    control_blunders: tuple[ControlBlunder, ...]
    suspects: tuple[Suspect, ...]
    on_bound: tuple[BoundHit, ...]
    model_doubt: str | None
    global_test: Mapping[str, object]
    estimation: Mapping[str, object]
    residuals: tuple[ResidualRow, ...]
    notes: tuple[str, ...]
    sigma0_px_estimated: float | None = None
    variance_scale: Mapping[str, object] | None = field(default=None)

    def __bool__(self) -> bool:
        """Falsy when the adjustment did not converge (``reason`` says why), as its result is."""
        return self.converged

    def used_residuals(self) -> tuple[ResidualRow, ...]:
        """The rows the adjustment used."""
        return tuple(row for row in self.residuals if row.used)

    def set_aside_residuals(self) -> tuple[ResidualRow, ...]:
        """The rows the adjustment set aside (their residuals are predictions)."""
        return tuple(row for row in self.residuals if not row.used)


__all__ = ["BoundHit", "CalibrationReport", "Correlation", "ParameterEstimate", "ResidualRow"]  # ParameterEstimate: the
# calibration's own (usvips.core.stereo_calibration), named here for the report's readers
