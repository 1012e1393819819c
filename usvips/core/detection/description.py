"""The description of a detection model: what the model file expects and what its output holds. It is
plain data; :mod:`usvips.io.model_description` reads it from a TOML or JSON file, and the family
(:mod:`usvips.core.detection.registry`) decodes the output it describes.
"""

from __future__ import annotations

from dataclasses import dataclass

#: the orders of colour channels a model may expect
CHANNEL_ORDERS = ("RGB", "BGR")


@dataclass(frozen=True)
class ModelDescription:
    """``model``: the model file as the description names it (relative to the description's folder);
    ``family``: the output layout's registered name (``yolo-pose``); ``input_width``/``input_height``:
    the network's input in pixels (the image is letterboxed into it: scaled to fit, centred, padded);
    normalisation per channel: value = (pixel · ``scale`` − ``mean``) / ``std``, channels in
    ``channel_order``; ``class_names`` and ``keypoint_names`` in the model's order; ``keypoint_values``:
    numbers per keypoint in the output (3: x, y, visibility; 2: x, y); ``score_threshold`` (0..1) and
    ``iou_threshold`` (0..1) of the non-maximum suppression; ``pad_value`` the letterbox's grey (0..255)."""

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
    score_threshold: float = 0.25
    iou_threshold: float = 0.45
    pad_value: int = 114
    max_detections: int = 300
