"""Detectors: models that find objects and their keypoints in one image (:mod:`.detection`), the model
families that decode a network's output (:mod:`.registry`, one module per family under ``kinds``), the
ONNX runner (:mod:`.runner`) and the stereo pairing of detections through the housing (:mod:`.stereo`)."""

from usvips.core.detection.description import ModelDescription
from usvips.core.detection.detection import Detection, Detector, Keypoint
from usvips.core.detection.letterbox import Letterbox

__all__ = ["Detection", "Detector", "Keypoint", "Letterbox", "ModelDescription"]
