"""Calibration targets: boards and 3-D target fields, their descriptions and detectors (a registry of
kinds, one module each in ``kinds/``), and what a detection returns (:mod:`.detection`)."""

from usvips.core.calibration_targets.base import CalibrationTarget
from usvips.core.calibration_targets.detection import StereoView, TargetDetection, stereo_observations
from usvips.core.calibration_targets.registry import from_description, kind, names

__all__ = ["CalibrationTarget", "StereoView", "TargetDetection", "from_description", "kind", "names",
           "stereo_observations"]
