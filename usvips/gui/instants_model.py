"""An object's instants as the window lists them (free of Qt): each instant's figure ± σ, its weight in
the combination, its standardised residual and outlier flag, and the combined figure with the share of its
σ² that the between-instant spread contributes and the agreement test's p-value.

The numbers are the one figure path's (:func:`usvips.app.project_figures.evaluate` for the combination,
:func:`~usvips.app.project_figures.instant_measurements` for each instant): this module only arranges
them. An instant's weight is the one the combination used (:attr:`CombinedFigure.weights`): its share of
Σ w*_i with w*_i = 1 / ((1 − ρ_i) σ_i² + τ̂²), σ_i its pointing sigma (the part independent between
instants), ρ_i the share of it a model repeats from frame to frame (0 for a person's picks) and τ̂ the
between-instant standard deviation (:mod:`usvips.core.measurements.instants`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.app.object_instants import has_tracked_instants
from usvips.app.project_figures import evaluate, instant_measurements, measurement_input
from usvips.core.errors import UsvipsError
from usvips.core.measurements import QualityRules, kind
from usvips.core.measurements.figures import Figure
from usvips.core.measurements.instants import CombinedFigure
from usvips.gui.calculator import format_figure
from usvips.store.interface import ProjectStore


@dataclass(frozen=True)
class InstantRow:
    """One instant of an object: the stored object holding it (``object_id``; the first row is the object
    itself), where it was measured (``video`` and left ``frame`` with its ``time_s``, or the image
    ``pair``), its main ``figure`` (value ± total σ), its ``weight`` (share 0..1 of the combination), its
    leave-one-out standardised ``residual`` (NaN with fewer than 3 instants) and whether it is an
    ``outlier``."""

    object_id: int
    video: str | None
    frame: int | None
    time_s: float | None
    pair: str | None
    figure: Figure
    weight: float
    residual: float
    outlier: bool

    @property
    def where(self) -> str:
        if self.video is not None and self.frame is not None:
            time = f", {self.time_s:.3f} s" if self.time_s is not None else ""
            return f"{self.video} frame {self.frame}{time}"
        return f"pair {self.pair}" if self.pair else "—"


@dataclass(frozen=True)
class ObjectInstants:
    """An object (``object_id``, of ``kind``) over its instants: ``rows`` in the order the combination
    takes them (the object's own first), ``combined`` its main figure combined (None: one instant);
    ``tracked``: some of its instants were made by tracking (their pick's error is kept whole in σ)."""

    object_id: int
    kind: str
    rows: tuple[InstantRow, ...]
    combined: CombinedFigure | None
    tracked: bool = False

    def summary(self) -> str:
        """The combined figure ± σ, the between-instant share of σ², the agreement test and the outliers
        (or the one instant's figure)."""
        if self.combined is None:
            return (f"object {self.object_id}: {format_figure(self.rows[0].figure)} on one instant "
                    "(store tracked instants, Ctrl+T, to combine several)")
        c = self.combined
        verdict = "the instants agree" if c.agree else "the instants disagree beyond their sigmas"
        text = (f"object {self.object_id}: {format_figure(c.figure)} over {c.count} instants — between-instant "
                f"spread {c.between_share:.0%} of σ²; χ²({c.dof}) = {c.q:.2f}, p = {c.p_value:.3f}: {verdict}")
        outlying = [r.object_id for r in self.rows if r.outlier]
        if outlying:
            text += "; outlying: " + ", ".join(f"object {i}" for i in outlying)
        if self.tracked:
            text += ("; tracked instants carry the error of the pick they were tracked from: it is kept whole "
                     "in σ (measure other frames by hand to average it out)")
        elif c.shared_fractions is not None and np.any(c.shared_fractions > 0):
            shared = c.shared_fractions[c.shared_fractions > 0]
            text += (f"; a model pointed at {len(shared)} of the instants: up to {shared.max():.0%} of their pointing "
                     "error repeats from frame to frame (the model's measured frame correlation) and is kept whole "
                     "in σ")
        return text


def whole_object(project: ProjectStore, object_id: int) -> int:
    """The object that ``object_id`` is an instant of (itself when it is no further instant)."""
    return project.instant_links().get(int(object_id), int(object_id))


def object_instants(project: ProjectStore, object_id: int, rules: QualityRules | None = None,
                    calibrations: dict | None = None) -> ObjectInstants:
    """The instants of stored object ``object_id`` (or of the object it is an instant of) with their
    figures, weights and outlier flags; an object whose figures cannot be computed (its instants on two
    calibrations, say) is an :class:`UsvipsError` naming it."""
    object_id = whole_object(project, object_id)
    stored = project.object(object_id)
    source = measurement_input(project, stored, calibrations)
    everything = [stored] + [project.object(i) for i in project.instants(object_id)]
    measured = instant_measurements(source, rules)
    main = _main_index(measured[0].figures, stored.kind)
    combined = None
    if len(everything) > 1:
        combined = evaluate(source, rules).combined[main]
        weights = combined.weights
        residuals = np.asarray(combined.residuals, float)
        outliers = set(combined.outliers)
    else:
        weights, residuals, outliers = np.ones(1), np.full(1, np.nan), set()
    rows = []
    for k, (instant, measurement) in enumerate(zip(everything, measured, strict=True)):
        vertex = instant.vertices[0] if instant.vertices else None
        on_video = vertex is not None and vertex.video is not None
        rows.append(InstantRow(instant.id, vertex.video if on_video else None,
                               int(vertex.frame_left) if on_video and vertex.frame_left is not None else None,
                               float(vertex.time_s) if on_video and vertex.time_s is not None else None,
                               vertex.pair if vertex is not None else None, measurement.figures[main],
                               float(weights[k]), float(residuals[k]), k in outliers))
    return ObjectInstants(object_id, stored.kind, tuple(rows), combined,
                          has_tracked_instants(project, object_id))


def _main_index(figures, kind_name: str) -> int:
    try:
        name = kind(kind_name).main_name()
    except UsvipsError:
        return 0
    return next((i for i, f in enumerate(figures) if f.name == name), 0)
