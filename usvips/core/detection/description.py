"""The description of a detection model: what the model file expects and what its output holds. It is
plain data; :mod:`usvips.io.model_description` reads it from a TOML or JSON file, and the family
(:mod:`usvips.core.detection.registry`) decodes the output it describes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from usvips.core.detection.keypoint_sigma import StereoSigma
from usvips.core.errors import InvalidParameterError

#: the orders of colour channels a model may expect
CHANNEL_ORDERS = ("RGB", "BGR")


@dataclass(frozen=True)
class ModelDescription:
    """``model``: the model file as the description names it (relative to the description's folder);
    ``family``: the output layout's registered name (``yolo-pose``); ``input_width``/``input_height``:
    the network's input in pixels (the image is letterboxed into it: scaled to fit, centred, padded);
    normalisation per channel: value = (pixel · ``scale`` − ``mean``) / ``std``, channels in
    ``channel_order``; ``class_names`` and ``keypoint_names`` in the model's order; ``keypoint_values``:
    numbers per keypoint in the output (3: x, y, visibility; 2: x, y); ``objectness``: whether an objectness
    score precedes the class scores (YOLOv5/v7-pose; the score is then objectness × class score);
    ``score_threshold`` (0..1) and ``iou_threshold`` (0..1) of the non-maximum suppression; ``pad_value`` the
    letterbox's grey (0..255); ``max_detections`` the most kept per image; ``keypoint_sigma_px``: the
    keypoints' MEASURED pointing sigmas ((name, px) pairs, one image coordinate; empty when never measured:
    :mod:`usvips.core.detection.keypoint_sigma`) and ``keypoint_sigma_basis`` what they were measured on;
    ``validated_keypoint_sigma``: each keypoint's pointing σ measured on held-out validation (pixels of the
    model's INPUT, one coordinate; in the keypoints' order; empty when not measured —
    :mod:`usvips.core.detection.validation`), used, scaled to image pixels by the letterbox, where the
    ``keypoint_sigma_px`` table gives none; ``validation_source`` what that validation was made on (one
    phrase, e.g. "150 held-out rendered frames"); ``stereo_sigma``: how its refined stereo keypoints err by the
    fish's size (:class:`~usvips.core.detection.keypoint_sigma.StereoSigma`, measured on rendered clips; None
    when never measured), which a length's σ then rests on; ``frame_correlation``: the correlation in [0, 1)
    of its lengths' pointing errors on one fish between frames (measured on rendered clips; None when never
    measured: a fish's lengths joined over frames then share their whole pointing error) and
    ``frame_correlation_basis`` what it was measured on."""

    model: str
    family: str
    input_width: int
    input_height: int
    class_names: tuple[str, ...]
    keypoint_names: tuple[str, ...]
    scale: float = 1.0 / 255.0
    mean: tuple[float, float, float] = (0.0, 0.0, 0.0)
    std: tuple[float, float, float] = (1.0, 1.0, 1.0)
    channel_order: str = "RGB"
    keypoint_values: int = 3
    objectness: bool = False
    score_threshold: float = 0.25
    iou_threshold: float = 0.45
    pad_value: int = 114
    max_detections: int = 300
    keypoint_sigma_px: tuple[tuple[str, float], ...] = ()
    keypoint_sigma_basis: str = ""
    validated_keypoint_sigma: tuple[float, ...] = ()
    validation_source: str = ""
    stereo_sigma: StereoSigma | None = None
    frame_correlation: float | None = None
    frame_correlation_basis: str = ""

    def __post_init__(self) -> None:
        if self.frame_correlation is not None and not 0.0 <= self.frame_correlation < 1.0:
            raise InvalidParameterError("frame_correlation", f"must lie in [0, 1), got {self.frame_correlation}")
        validated = self.validated_keypoint_sigma
        if validated and (len(validated) != len(self.keypoint_names) or not all(
                math.isfinite(v) and v > 0 for v in validated)):
            raise InvalidParameterError("validated_keypoint_sigma", f"expected {len(self.keypoint_names)} finite "
                                                                    f"numbers > 0 (one per keypoint), got "
                                                                    f"{list(validated)}")
        for name in ("input_width", "input_height", "max_detections"):
            if int(getattr(self, name)) < 1:
                raise InvalidParameterError(name, f"must be >= 1, got {getattr(self, name)}")
        if not (math.isfinite(self.scale) and self.scale > 0):
            raise InvalidParameterError("scale", f"must be finite and > 0, got {self.scale}")
        if len(self.mean) != 3 or len(self.std) != 3 or not all(math.isfinite(v) for v in (*self.mean, *self.std)) \
                or min(self.std) <= 0:
            raise InvalidParameterError("std", f"mean and std need 3 finite values each, std > 0; got mean "
                                               f"{self.mean}, std {self.std}")
        if self.channel_order not in CHANNEL_ORDERS:
            raise InvalidParameterError("channels", f"must be one of {', '.join(CHANNEL_ORDERS)}, got "
                                                    f"{self.channel_order!r}")
        for name in ("score_threshold", "iou_threshold"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise InvalidParameterError(name, f"must lie in [0, 1], got {getattr(self, name)}")
        if len(set(self.keypoint_names)) != len(self.keypoint_names):
            raise InvalidParameterError("keypoints", f"names repeat: {self.keypoint_names}")
        for name, sigma in self.keypoint_sigma_px:
            if name not in self.keypoint_names:
                raise InvalidParameterError("keypoint_sigma", f"{name!r} is not one of the model's keypoints "
                                                              f"({', '.join(self.keypoint_names)})")
            if not (math.isfinite(sigma) and sigma > 0):
                raise InvalidParameterError("keypoint_sigma", f"{name}: expected a finite sigma > 0 px, got {sigma}")

    def measured_sigma(self, name: str) -> float | None:
        """The measured pointing sigma (px) of keypoint ``name``; None when it was never measured."""
        return dict(self.keypoint_sigma_px).get(name)
