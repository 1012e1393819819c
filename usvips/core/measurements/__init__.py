"""Measured objects: the measurement-kind registry (one module per kind in ``kinds``), figures with
sigmas from the vertices' joint covariance, the quality rules, and the one function that computes every
object's figures (:func:`measure`, :func:`measure_picks`)."""

from usvips.core.measurements.figures import Figure, QualityRules, propagate, propagate_all
from usvips.core.measurements.registry import (
    DRAWINGS,
    LEGACY,
    MeasurementKind,
    UnknownKindError,
    kind,
    names,
    registered_kinds,
    resolve,
)

__all__ = ["DRAWINGS", "LEGACY", "Figure", "Measurement", "MeasurementKind", "QualityRules", "UnknownKindError",
           "calibration_marks", "intersect_vertices", "kind", "measure", "measure_picks", "names", "placement",
           "propagate", "propagate_all", "registered_kinds", "resolve", "vertex_covariance_parts"]

#: the names :mod:`usvips.core.measurements.evaluate` gives, imported when first asked for: evaluating needs
#: the calibration model and its uncertainty, which a reader of kinds and rules (the project store opening
#: a survey, the window's start) does not
_EVALUATE = ("Measurement", "calibration_marks", "intersect_vertices", "measure", "measure_picks", "placement",
             "vertex_covariance_parts")


def __getattr__(name: str):
    if name in _EVALUATE:
        from usvips.core.measurements import evaluate

        return getattr(evaluate, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
