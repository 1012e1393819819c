"""A figure combined over the instants of one object (a fish measured on several video frames): the record
that :mod:`usvips.core.measurements.instants` computes and that a
:class:`~usvips.core.measurements.evaluate.Measurement` carries. Its own module so that the two meet here
rather than import each other."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.core.measurements.figures import Figure

#: significance of the agreement test and of the outlier limit (family-wise over the instants)
ALPHA = 0.05


@dataclass(frozen=True)
class CombinedFigure:
    """A figure combined over ``count`` instants (units of ``unit``).

    ``value`` ± ``sigma``: the random-effects mean and its standard deviation (common part included);
    ``tau``: the estimated between-instant standard deviation; ``between_share``: the share (0..1) of
    sigma² that the between-instant spread contributes (0 when the instants agree within their sigmas);
    ``q``, ``dof``, ``p_value``: Cochran's χ² test that the instants agree (``agree`` when p ≥ α);
    ``residuals``: each instant's leave-one-out standardised residual (NaN with fewer than 3 instants);
    ``outliers``: the indices of the instants beyond ``limit``; ``labels``: the instants' names;
    ``weights``: each instant's weight in the mean (summing to 1); ``shared_fractions``: the share ρ_i of
    each instant's pointing error that does not average out (0: independent; all 1 with
    ``shared_pointing``: one pick's error carried along by tracking).
    """

    name: str
    unit: str
    value: float
    sigma: float
    count: int
    tau: float
    between_share: float
    q: float
    dof: int
    p_value: float
    residuals: np.ndarray
    limit: float
    outliers: tuple[int, ...]
    labels: tuple[str, ...]
    weights: np.ndarray | None = None
    shared_fractions: np.ndarray | None = None
    shared_pointing: bool = False

    @property
    def agree(self) -> bool:
        return self.p_value >= ALPHA

    @property
    def figure(self) -> Figure:
        """The combined figure as any other figure (the object list, the calculator, the exports)."""
        return Figure(self.name, self.value, self.sigma, self.unit)

    @property
    def outlier_labels(self) -> tuple[str, ...]:
        return tuple(self.labels[i] for i in self.outliers)

    def summary(self) -> str:
        """One line: value ± sigma over k instants, τ and its share, the test and the outliers."""
        scale, unit = (1000.0, "mm") if self.unit == "m" else (1.0, self.unit)
        text = (f"{self.name} {self.value * scale:.1f} ± {self.sigma * scale:.1f} {unit} over {self.count} instants"
                f" (between-instant sd {self.tau * scale:.1f} {unit}, {self.between_share:.0%} of σ²; "
                f"χ²({self.dof}) = {self.q:.2f}, p = {self.p_value:.3f})")
        if self.outliers:
            text += "; outlying: " + ", ".join(self.outlier_labels)
        return text
