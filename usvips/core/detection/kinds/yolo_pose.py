"""The common YOLO-pose output layout (YOLOv8/v11 pose heads exported to ONNX): one tensor of
[1, C, N] (or [1, N, C]) with C = 4 + classes + values·K — per candidate the box centre x, y and size w, h
in the input's pixels, one score per class (already a probability), then K keypoints × (x, y, visibility)
(``keypoint_values`` 3) or × (x, y) (2, then every keypoint's confidence is the detection's score). With
``objectness`` (YOLOv5/v7-pose heads) an objectness probability precedes the class scores, C grows by one
and a candidate's class score is objectness × class probability.
Candidates under the score threshold are dropped, the rest suppressed per class (OpenCV's batched
non-maximum suppression) and mapped back through the letterbox.
"""

from __future__ import annotations

import cv2
import numpy as np

from usvips.core.detection.description import ModelDescription
from usvips.core.detection.detection import Detection, Keypoint
from usvips.core.detection.letterbox import Letterbox
from usvips.core.detection.registry import ModelFamily
from usvips.core.errors import InvalidParameterError


def channel_count(description: ModelDescription) -> int:
    """C: the numbers per candidate the layout holds."""
    return (4 + int(description.objectness) + len(description.class_names)
            + description.keypoint_values * len(description.keypoint_names))


def candidates(output: np.ndarray, description: ModelDescription) -> np.ndarray:
    """The output as (N, C) rows, one per candidate, whichever axis holds the channels (both, when N = C:
    then [1, C, N], as YOLO exports it)."""
    array = np.asarray(output, dtype=np.float64)
    if array.ndim == 3 and array.shape[0] == 1:
        array = array[0]
    channels = channel_count(description)
    if array.ndim != 2 or channels not in array.shape:
        raise InvalidParameterError("output", f"the model's output has shape {np.shape(output)}; the description "
                                              f"asks for [1, {channels}, N] or [1, N, {channels}] (4 box values, "
                                              f"{'objectness, ' if description.objectness else ''}"
                                              f"{len(description.class_names)} class score(s), "
                                              f"{len(description.keypoint_names)} keypoints × "
                                              f"{description.keypoint_values})")
    return array.T if array.shape[0] == channels else array  # square (N = C): [1, C, N], YOLO's export


class YoloPose(ModelFamily):
    kind = "yolo-pose"

    @classmethod
    def check(cls, description: ModelDescription) -> None:
        if description.keypoint_values not in (2, 3):
            raise InvalidParameterError("keypoint_values", f"the yolo-pose layout has 2 or 3 values per keypoint, "
                                                           f"got {description.keypoint_values}")
        if not description.class_names:
            raise InvalidParameterError("classes", "the yolo-pose layout needs at least one class")

    @classmethod
    def decode(cls, output: np.ndarray, description: ModelDescription, letterbox: Letterbox) -> tuple[Detection, ...]:
        cls.check(description)
        rows = candidates(output, description)
        classes = len(description.class_names)
        first = 4 + int(description.objectness)
        scores_all = rows[:, first:first + classes]
        if description.objectness:
            scores_all = scores_all * rows[:, 4:5]
        class_ids = np.argmax(scores_all, axis=1)
        scores = scores_all[np.arange(len(rows)), class_ids]
        keep = np.flatnonzero(np.isfinite(scores) & (scores >= description.score_threshold)
                              & np.all(np.isfinite(rows[:, :4]), axis=1) & (rows[:, 2] >= 0) & (rows[:, 3] >= 0))
        if keep.size == 0:
            return ()
        rows, class_ids, scores = rows[keep], class_ids[keep], scores[keep]
        cx, cy, w, h = rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3]
        rects = np.column_stack([cx - w / 2, cy - h / 2, w, h])
        chosen = np.asarray(cv2.dnn.NMSBoxesBatched(rects.tolist(), scores.tolist(), class_ids.astype(int).tolist(),
                                                    float(description.score_threshold),
                                                    float(description.iou_threshold)), dtype=int).reshape(-1)
        chosen = chosen[np.argsort(-scores[chosen], kind="stable")][:description.max_detections]
        rows, class_ids, scores = rows[chosen], class_ids[chosen], scores[chosen]
        x0, y0 = letterbox.to_image(rows[:, 0] - rows[:, 2] / 2, rows[:, 1] - rows[:, 3] / 2)
        x1, y1 = letterbox.to_image(rows[:, 0] + rows[:, 2] / 2, rows[:, 1] + rows[:, 3] / 2)
        values = description.keypoint_values
        points = rows[:, first + classes:].reshape(len(rows), len(description.keypoint_names), values)
        kx, ky = letterbox.to_image(points[:, :, 0], points[:, :, 1])
        confidence = points[:, :, 2] if values == 3 else np.repeat(scores[:, None], points.shape[1], axis=1)
        names = description.keypoint_names
        return tuple(
            Detection((float(x0[i]), float(y0[i]), float(x1[i]), float(y1[i])), description.class_names[class_ids[i]],
                      float(scores[i]), tuple(Keypoint(name, float(kx[i, k]), float(ky[i, k]), float(confidence[i, k]))
                                              for k, name in enumerate(names)))
            for i in range(len(rows)))
