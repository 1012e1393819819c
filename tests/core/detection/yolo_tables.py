"""Synthetic YOLO-pose output tables with known truth: detections in image pixels written into the
network's input coordinates through a letterbox, with lower-scored near-duplicates (that the suppression
must remove) and candidates below the score threshold."""

from __future__ import annotations

import numpy as np

from usvips.core.detection import Letterbox, ModelDescription


def random_truth(rng: np.random.Generator, count: int, image_size: tuple[int, int], keypoints: int,
                 classes: int) -> list[dict]:
    """``count`` well-separated objects: box (x0, y0, x1, y1), class index, score, keypoints (K, 3)."""
    w, h = image_size
    truth: list[dict] = []
    while len(truth) < count:
        bw, bh = rng.uniform(40, 200), rng.uniform(20, 100)
        x0, y0 = rng.uniform(0, w - bw - 1), rng.uniform(0, h - bh - 1)
        box = np.array([x0, y0, x0 + bw, y0 + bh])
        if any(_overlap(box, t["box"]) for t in truth):
            continue
        points = np.column_stack([rng.uniform(x0, x0 + bw, keypoints), rng.uniform(y0, y0 + bh, keypoints),
                                  rng.uniform(0.05, 1.0, keypoints)])
        truth.append({"box": box, "class": int(rng.integers(classes)), "score": rng.uniform(0.5, 0.99),
                      "keypoints": points})
    return truth


def _overlap(a: np.ndarray, b: np.ndarray) -> bool:
    return not (a[2] < b[0] or b[2] < a[0] or a[3] < b[1] or b[3] < a[1])


def row(box: np.ndarray, class_index: int, score: float, points: np.ndarray, letterbox: Letterbox,
        classes: int, values: int = 3, objectness: bool = False) -> np.ndarray:
    """One candidate's numbers in the input's coordinates (with ``objectness``, the score split into an
    objectness and a class probability whose product it is)."""
    u0, v0 = letterbox.to_input(box[0], box[1])
    u1, v1 = letterbox.to_input(box[2], box[3])
    scores = np.zeros(classes)
    scores[class_index] = np.sqrt(score) if objectness else score
    if objectness:
        scores = np.concatenate([[np.sqrt(score)], scores])
    pu, pv = letterbox.to_input(points[:, 0], points[:, 1])
    per_point = np.column_stack([pu, pv, points[:, 2]])[:, :values]
    return np.concatenate([[(u0 + u1) / 2, (v0 + v1) / 2, u1 - u0, v1 - v0], scores, per_point.ravel()])


def table(rng: np.random.Generator, truth: list[dict], description: ModelDescription, letterbox: Letterbox,
          channels_first: bool = True) -> np.ndarray:
    """[1, C, N] (or [1, N, C], never square: that reads as [1, C, N]) holding the truth, a weaker shifted
    duplicate of each (IoU > 0.8) and candidates below the score threshold, in random order."""
    layout = (len(description.class_names), description.keypoint_values, description.objectness)
    rows = []
    for t in truth:
        rows.append(row(t["box"], t["class"], t["score"], t["keypoints"], letterbox, *layout))
        shift = 0.02 * (t["box"][2] - t["box"][0])
        rows.append(row(t["box"] + shift, t["class"], t["score"] * 0.9, t["keypoints"] + [3, 3, 0], letterbox,
                        *layout))
        rows.append(row(t["box"] * 0.5, t["class"], description.score_threshold * 0.5, t["keypoints"], letterbox,
                        *layout))
    if not channels_first and len(rows) == len(rows[0]):  # [1, N, N] reads as [1, C, N]: one more, weak row
        rows.append(row(truth[0]["box"], truth[0]["class"], 0.0, truth[0]["keypoints"], letterbox, *layout))
    rows = np.array(rows)[rng.permutation(len(rows))]
    return (rows.T if channels_first else rows)[None]
