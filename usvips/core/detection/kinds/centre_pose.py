"""The centre-pose layout (CenterNet-style keypoints, the family of USVIPS's own fish model): one tensor
[1, C, H, W] on a grid of ``stride`` = input width / W input pixels per cell, with, for one class and K
keypoints, C = 1 + 2 + 4 + 2K + K + 2 channels in this order:

| channels | meaning |
|---|---|
| 1 | centre heatmap (a probability): an object's centre (the midpoint of its first two keypoints) lies here |
| 2 | the centre's sub-cell offset x, y (cells, 0..1) |
| 4 | the box's extent left, up, right, down from the centre (cells) |
| 2K | each keypoint's displacement x, y from the cell (cells) |
| K | keypoint heatmaps (probabilities): keypoint k lies in this cell |
| 2 | the keypoints' sub-cell offset x, y (cells, 0..1; shared by the keypoint heatmaps) |

A grid position (j, i) with offset (ox, oy) is the input point ((j + ox)·stride, (i + oy)·stride) (corner
origin, as YOLO's). Decoding, vectorised: centres are the local maxima (3 × 3) of the centre heatmap at or
above ``score_threshold`` (the score); each keypoint is first the centre's cell plus its displacement. The
first two keypoints (snout and fork) then move together to the pair of their heatmaps' local maxima
(≥ :data:`PEAK_THRESHOLD`, in the detection's box grown by a quarter of its size) that fits best: the pair's
midpoint near the centre, each point near its displaced point, strong peaks before weak ones (the costs
below; a displaced point may stay where no peak fits). The centre heatmap places an object's midpoint far
better than the displacements place its ends (measured on the shipped fish model: displacement errors of
20-50 % of a fish's length, against a few pixels for the centre), so the midpoint binds the pair. Every
later keypoint is first shifted as the nearer of the first two was (from its displaced point to its peak:
one detection's displacements share much of their error), then moves to its own heatmap's nearest local
maximum in the grown box within half the box's larger side. A keypoint's confidence is its peak's value
(or the heatmap's value at the displaced point when it kept it). Overlapping boxes are then suppressed
(OpenCV's NMS at ``iou_threshold``) and the best ``max_detections`` kept, mapped back through the letterbox.
"""

from __future__ import annotations

import cv2
import numpy as np

from usvips.core.detection.description import ModelDescription
from usvips.core.detection.detection import Detection, Keypoint
from usvips.core.detection.letterbox import Letterbox
from usvips.core.detection.registry import ModelFamily
from usvips.core.errors import InvalidParameterError

#: a keypoint heatmap's local maximum counts as a peak from this value
PEAK_THRESHOLD = 0.1
#: the first two keypoints' choice: the weight of each one's distance from its displaced point, against the
#: distance of the pair's midpoint from the centre (weight 1)
DISPLACEMENT_WEIGHT = 0.1
#: the first two keypoints' choice: the cost of a peak's doubt (1 − its value, × the box's larger side)
PEAK_VALUE_COST = 0.5
#: the first two keypoints' choice: the cost of keeping a displaced point instead of a peak (× the box's side)
NO_PEAK_COST = 1.0


def channel_slices(keypoints: int) -> dict[str, slice]:
    """The channels of each quantity for ``keypoints`` keypoints (one class)."""
    k = int(keypoints)
    starts = {"centre": 1, "centre_offset": 2, "extent": 4, "displacement": 2 * k, "keypoint_heat": k,
              "keypoint_offset": 2}
    out, first = {}, 0
    for name, size in starts.items():
        out[name] = slice(first, first + size)
        first += size
    return out


def channel_count(keypoints: int) -> int:
    """C: the channels the layout has for ``keypoints`` keypoints."""
    return 9 + 3 * int(keypoints)


def _peaks(heat: np.ndarray, threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns of the 3 × 3 local maxima of ``heat`` at or above ``threshold``."""
    heat = np.ascontiguousarray(heat, dtype=np.float32)
    peak = (heat >= cv2.dilate(heat, np.ones((3, 3), np.uint8))) & (heat >= threshold)
    return np.nonzero(peak)


def _peak_points(heat: np.ndarray, offset: np.ndarray, stride_x: float, stride_y: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One keypoint heatmap's peaks: their input points x, y (pixels, sub-cell offsets added) and values."""
    rows, cols = _peaks(heat, PEAK_THRESHOLD)
    return (cols + offset[0, rows, cols]) * stride_x, (rows + offset[1, rows, cols]) * stride_y, heat[rows, cols]


def _inside(px: np.ndarray, py: np.ndarray, box: tuple[np.ndarray, ...]) -> np.ndarray:
    """(N, P): whether each peak lies in each detection's box grown by a quarter of its size."""
    x0, y0, x1, y1 = box
    grow_x, grow_y = (x1 - x0) / 4, (y1 - y0) / 4
    return ((px[None, :] >= (x0 - grow_x)[:, None]) & (px[None, :] <= (x1 + grow_x)[:, None])
            & (py[None, :] >= (y0 - grow_y)[:, None]) & (py[None, :] <= (y1 + grow_y)[:, None]))


def _snap_nearest(peaks: tuple[np.ndarray, ...], j: int, kx: np.ndarray, ky: np.ndarray, confidence: np.ndarray,
                  box: tuple[np.ndarray, ...]) -> None:
    """Move keypoint ``j`` of every detection (in place) to its heatmap's nearest peak in the grown box and
    within half the box's larger side of the displaced point, taking that peak's value as its confidence."""
    px, py, value = peaks
    if px.size == 0:
        return
    side = np.maximum(box[2] - box[0], box[3] - box[1])
    distance = np.hypot(px[None, :] - kx[j][:, None], py[None, :] - ky[j][:, None])  # (N, P)
    distance = np.where(_inside(px, py, box) & (distance <= side[:, None] / 2), distance, np.inf)
    best = np.argmin(distance, axis=1)
    found = np.isfinite(distance[np.arange(len(best)), best])
    kx[j, found], ky[j, found] = px[best[found]], py[best[found]]
    confidence[j, found] = value[best[found]]


def _snap_pair(peaks: list[tuple[np.ndarray, ...]], kx: np.ndarray, ky: np.ndarray, confidence: np.ndarray,
               centre: tuple[np.ndarray, np.ndarray], box: tuple[np.ndarray, ...]) -> None:
    """Move the first two keypoints of every detection (in place) to the pair of their heatmaps' peaks (or
    displaced points) that best fits the detection: the pair's midpoint near the centre (the centre IS
    their midpoint in this layout, and the centre heatmap places it well), each point near its displaced
    point (weighted :data:`DISPLACEMENT_WEIGHT`), a displaced point kept instead of a peak costing
    :data:`NO_PEAK_COST` × the box's larger side. Only peaks in the grown box count."""
    side = np.maximum(box[2] - box[0], box[3] - box[1])
    n = len(side)
    points, costs = [], []
    for j, (px, py, value) in enumerate(peaks):
        # candidates (N, P + 1): each peak, then the detection's displaced point
        cx = np.column_stack([np.broadcast_to(px, (n, px.size)), kx[j]])
        cy = np.column_stack([np.broadcast_to(py, (n, py.size)), ky[j]])
        values = np.column_stack([np.broadcast_to(value, (n, value.size)), confidence[j]])
        usable = np.column_stack([_inside(px, py, box), np.ones(n, bool)])
        own = DISPLACEMENT_WEIGHT * np.hypot(cx - kx[j][:, None], cy - ky[j][:, None])
        own = own + PEAK_VALUE_COST * side[:, None] * (1 - np.clip(values, 0, 1))
        own[:, -1] = NO_PEAK_COST * side
        points.append((cx, cy, values))
        costs.append(np.where(usable, own, np.inf))
    (ax, ay, av), (bx, by, bv) = points
    midpoint = np.hypot(ax[:, :, None] + bx[:, None, :] - 2 * centre[0][:, None, None],
                        ay[:, :, None] + by[:, None, :] - 2 * centre[1][:, None, None]) / 2
    total = (midpoint + costs[0][:, :, None] + costs[1][:, None, :]).reshape(n, -1)
    a, b = np.divmod(np.argmin(total, axis=1), bx.shape[1])
    rows = np.arange(n)
    kx[0], ky[0], confidence[0] = ax[rows, a], ay[rows, a], av[rows, a]
    kx[1], ky[1], confidence[1] = bx[rows, b], by[rows, b], bv[rows, b]


def _anchor_later(kx: np.ndarray, ky: np.ndarray, regressed_x: np.ndarray, regressed_y: np.ndarray) -> None:
    """Move every keypoint after the first two (in place) by the shift its nearer one of the first two took
    from its displaced point to its peak: the displacements of one detection share much of their error."""
    for j in range(2, len(kx)):
        gaps = np.hypot(regressed_x[:2] - regressed_x[j], regressed_y[:2] - regressed_y[j])  # (2, N)
        anchor = np.argmin(gaps, axis=0)
        n = np.arange(kx.shape[1])
        kx[j] += kx[anchor, n] - regressed_x[anchor, n]
        ky[j] += ky[anchor, n] - regressed_y[anchor, n]


class CentrePose(ModelFamily):
    kind = "centre-pose"
    order = 1

    @classmethod
    def check(cls, description: ModelDescription) -> None:
        if len(description.class_names) != 1:
            raise InvalidParameterError("classes", f"the centre-pose layout has exactly one class, got "
                                                   f"{len(description.class_names)}")
        if not description.keypoint_names:
            raise InvalidParameterError("keypoints", "the centre-pose layout needs at least one keypoint")

    @classmethod
    def decode(cls, output: np.ndarray, description: ModelDescription, letterbox: Letterbox) -> tuple[Detection, ...]:
        cls.check(description)
        k = len(description.keypoint_names)
        array = np.asarray(output, dtype=np.float64)
        if array.ndim != 4 or array.shape[0] != 1 or array.shape[1] != channel_count(k):
            raise InvalidParameterError("output", f"the model's output has shape {np.shape(output)}; the centre-pose "
                                                  f"layout with {k} keypoints asks for [1, {channel_count(k)}, H, W]")
        maps = array[0]
        height, width = maps.shape[1:]
        stride_x, stride_y = description.input_width / width, description.input_height / height
        c = channel_slices(k)
        rows, cols = _peaks(maps[c["centre"]][0], description.score_threshold)
        if rows.size == 0:
            return ()
        scores = maps[0, rows, cols]
        offset = maps[c["centre_offset"]][:, rows, cols]
        cx, cy = (cols + offset[0]) * stride_x, (rows + offset[1]) * stride_y
        extent = np.maximum(maps[c["extent"]][:, rows, cols], 0.0)
        x0, y0 = cx - extent[0] * stride_x, cy - extent[1] * stride_y
        x1, y1 = cx + extent[2] * stride_x, cy + extent[3] * stride_y
        displacement = maps[c["displacement"]][:, rows, cols].reshape(k, 2, -1)
        kx = (cols[None, :] + displacement[:, 0]) * stride_x  # (K, N) input pixels
        ky = (rows[None, :] + displacement[:, 1]) * stride_y
        heat = maps[c["keypoint_heat"]]
        keypoint_offset = maps[c["keypoint_offset"]]
        grid_x = np.clip(np.floor(kx / stride_x), 0, width - 1).astype(int)
        grid_y = np.clip(np.floor(ky / stride_y), 0, height - 1).astype(int)
        confidence = heat[np.arange(k)[:, None], grid_y, grid_x]
        box = (x0, y0, x1, y1)
        peaks = [_peak_points(heat[j], keypoint_offset, stride_x, stride_y) for j in range(k)]
        paired = 2 if k >= 2 else 0
        if paired:
            regressed_x, regressed_y = kx.copy(), ky.copy()
            _snap_pair(peaks[:2], kx, ky, confidence, (cx, cy), box)
            _anchor_later(kx, ky, regressed_x, regressed_y)
        for j in range(paired, k):
            _snap_nearest(peaks[j], j, kx, ky, confidence, box)
        rects = np.column_stack([x0, y0, x1 - x0, y1 - y0])
        chosen = np.asarray(cv2.dnn.NMSBoxes(rects.tolist(), scores.tolist(), float(description.score_threshold),
                                             float(description.iou_threshold)), dtype=int).reshape(-1)
        chosen = chosen[np.argsort(-scores[chosen], kind="stable")][:description.max_detections]
        bx0, by0 = letterbox.to_image(x0[chosen], y0[chosen])
        bx1, by1 = letterbox.to_image(x1[chosen], y1[chosen])
        px, py = letterbox.to_image(kx[:, chosen], ky[:, chosen])
        confidence = np.clip(confidence[:, chosen], 0.0, 1.0)
        names, label = description.keypoint_names, description.class_names[0]
        return tuple(
            Detection((float(bx0[i]), float(by0[i]), float(bx1[i]), float(by1[i])), label, float(scores[chosen[i]]),
                      tuple(Keypoint(name, float(px[j, i]), float(py[j, i]), float(confidence[j, i]))
                            for j, name in enumerate(names)))
            for i in range(len(chosen)))
