"""The fish keypoint model's training targets on its output grid (numpy only; the training in
:mod:`usvips.training.fish_model` turns them into tensors).

A training frame is an INPUT × INPUT input (BGR uint8) with its fish, each a dict (see
:mod:`usvips.training.fish_augment`): ``keypoints`` (K × 2, input coordinates, origin at the input's top-left
corner), ``visible`` and ``in_frame`` (K booleans), ``box`` (u0, v0, u1, v1), ``required`` (a fish the model
must find) and, optionally, ``known`` (K booleans; all True when absent) and ``background_known`` (True when
absent). A keypoint that is not ``known`` was never labelled — the caudal tips of a fish from a reviewed
training set, which stores snout and fork only — so its heatmap is neither taught as present nor as absent on
that frame (``keypoint_ignore``) and its displacements are not taught. A fish whose ``background_known`` is
False comes from a frame where not every fish is labelled (a reviewed crop: a fish nobody accepted may lie in
it), so the frame teaches background only inside such fish's boxes (no second fish and no stray keypoint
within a labelled fish's box, and the shape of its peaks): its heatmaps' negatives elsewhere are ignored.
Rendered frames know every keypoint and their background, and their targets do not depend on either key.
"""

from __future__ import annotations

import math

import numpy as np

from usvips.core.synth.fish_scene import KEYPOINTS

INPUT = 256  # the training input's side (pixels)
STRIDE = 4  # input pixels per output cell
KEYPOINT_SIGMA_CELLS = 0.9


def _gaussian(shape: tuple[int, int], cx: float, cy: float, sigma: float) -> np.ndarray:
    ys, xs = np.arange(shape[0])[:, None], np.arange(shape[1])[None, :]
    return np.exp(-((xs - cx) ** 2 + (ys - cy) ** 2) / (2 * sigma**2))


def _neighbourhood(i: int, j: int, g: int) -> list[tuple[int, int]]:
    """The cells (row, column) of the 3 × 3 block around cell (i, j) that lie in a g × g grid: a centre's
    displacements are taught there, not only at its own cell, because the decoder reads them at the centre
    heatmap's peak, which may fall one cell off."""
    return [(i + di, j + dj) for di in (-1, 0, 1) for dj in (-1, 0, 1) if 0 <= i + di < g and 0 <= j + dj < g]


def targets(fish: list[dict], flip: bool) -> dict[str, np.ndarray]:
    """Training targets on the output grid for one frame's fish (input coordinates), optionally mirrored
    left-right (the keypoints keep their names: a fish facing the other way).

    ``ignore`` (g × g) weighs the heatmaps' negatives (0 where a fish that is not required lies: neither a fish
    nor background; 0 outside the labelled fish's boxes on a frame whose background is not known);
    ``keypoint_ignore`` (K × g × g) is the same per keypoint heatmap, and 0 over the whole frame for a keypoint
    some fish of the frame does not know."""
    g = INPUT // STRIDE
    k = len(KEYPOINTS)
    centre_heat = np.zeros((g, g), np.float32)
    keypoint_heat = np.zeros((k, g, g), np.float32)
    ignore = np.ones((g, g), np.float32)
    centre_offset = np.zeros((2, g, g), np.float32)
    extent = np.zeros((4, g, g), np.float32)
    displacement = np.zeros((2 * k, g, g), np.float32)
    displacement_mask = np.zeros((2 * k, g, g), np.float32)
    centre_mask = np.zeros((g, g), np.float32)
    keypoint_offset = np.zeros((2, g, g), np.float32)
    keypoint_mask = np.zeros((g, g), np.float32)
    unknown = np.zeros(k, bool)  # a keypoint some fish of the frame does not know
    background_known = True
    labelled = np.zeros((g, g), np.float32)  # the boxes of fish whose frame's background is not known
    claimed = np.full((g, g), np.inf)  # distance (cells) from each cell to the centre whose displacements it holds
    for f in fish:
        known = np.asarray(f.get("known", np.ones(k, bool)), bool)
        unknown |= ~known
        if not f.get("background_known", True):
            background_known = False
        points = np.array(f["keypoints"], np.float64) / STRIDE
        x0, y0, x1, y1 = (np.array(f["box"], np.float64) / STRIDE)
        if flip:
            points[:, 0] = g - points[:, 0]
            x0, x1 = g - x1, g - x0
        centre = points[:2].mean(axis=0)
        size = max(np.hypot(*(points[0] - points[1])), 1.0)
        sigma = max(0.8, 0.12 * size)
        if not (0 <= centre[0] < g and 0 <= centre[1] < g):
            continue
        j, i = int(centre[0]), int(centre[1])
        if not f["required"]:  # neither a fish to find nor background
            ignore = np.minimum(ignore, 1 - (_gaussian((g, g), j, i, 1.5 * sigma) > 0.1))
            continue
        if not f.get("background_known", True):
            r0, r1 = max(int(np.floor(y0)), 0), min(int(np.ceil(y1)), g - 1)
            c0, c1 = max(int(np.floor(x0)), 0), min(int(np.ceil(x1)), g - 1)
            labelled[r0:r1 + 1, c0:c1 + 1] = 1.0
        centre_heat = np.maximum(centre_heat, _gaussian((g, g), j, i, sigma))  # peaks of 1 at the cell
        centre_mask[i, j] = 1
        centre_offset[:, i, j] = centre - (j, i)
        extent[:, i, j] = (centre[0] - x0, centre[1] - y0, x1 - centre[0], y1 - centre[1])
        for ni, nj in _neighbourhood(i, j, g):
            gap = math.hypot(centre[0] - nj - 0.5, centre[1] - ni - 0.5)
            if gap >= claimed[ni, nj]:
                continue
            claimed[ni, nj] = gap
            for n in range(k):
                inside = bool(f["in_frame"][n]) and bool(known[n])
                displacement[2 * n:2 * n + 2, ni, nj] = points[n] - (nj, ni) if inside else 0.0
                displacement_mask[2 * n:2 * n + 2, ni, nj] = float(inside)
        for n in range(k):
            if not known[n] or not f["in_frame"][n] or not f["visible"][n]:
                continue
            pj, pi = int(points[n][0]), int(points[n][1])
            if 0 <= pj < g and 0 <= pi < g:
                keypoint_heat[n] = np.maximum(keypoint_heat[n], _gaussian((g, g), pj, pi, KEYPOINT_SIGMA_CELLS))
                keypoint_offset[:, pi, pj] = points[n] - (pj, pi)
                keypoint_mask[pi, pj] = 1
    if not background_known:
        ignore *= labelled
    keypoint_ignore = np.repeat(ignore[None], k, axis=0)
    keypoint_ignore[unknown] = 0.0
    return {"centre_heat": centre_heat, "ignore": ignore, "centre_mask": centre_mask, "centre_offset": centre_offset,
            "extent": extent, "displacement": displacement, "displacement_mask": displacement_mask,
            "keypoint_heat": keypoint_heat, "keypoint_offset": keypoint_offset, "keypoint_mask": keypoint_mask,
            "keypoint_ignore": keypoint_ignore}
