"""Where object labels go so that none covers another (Qt-free).

Each label is drawn above and to the right of its object's first vertex. Two objects close together on
one frame (two fish side by side) put their labels on top of each other, unreadable. :func:`stack_labels`
moves a label that would overlap one already placed up by one label height at a time (then down, if
that runs out of room), in screen pixels — labels keep their size on screen whatever the zoom, so the
layout is made again when the zoom changes."""

from __future__ import annotations

import numpy as np

#: how many label heights a label may move before it is left where it overlaps
MAX_STEPS = 12


def stack_labels(anchors: np.ndarray, sizes: np.ndarray, gap: float = 2.0) -> np.ndarray:
    """Vertical offsets (N,) in screen pixels (negative: up) for labels whose default boxes have their
    bottom-left corner at ``anchors`` (N, 2) screen pixels (x right, y down) and are ``sizes`` (N, 2)
    (width, height) pixels, such that no two boxes overlap (within ``gap``) where that can be reached in
    :data:`MAX_STEPS` moves. Labels are placed in order of their anchors (top to bottom, then left to
    right); the first keeps its place."""
    anchors = np.asarray(anchors, dtype=np.float64).reshape(-1, 2)
    sizes = np.asarray(sizes, dtype=np.float64).reshape(-1, 2)
    offsets = np.zeros(len(anchors))
    placed: list[tuple[float, float, float, float]] = []  # left, top, right, bottom
    for k in np.lexsort((anchors[:, 0], anchors[:, 1])):
        (x, y), (width, height) = anchors[k], sizes[k]
        step = height + gap
        for offset in [0.0] + [s * step for n in range(1, MAX_STEPS + 1) for s in (-n, n)]:
            box = (x, y - height + offset, x + width, y + offset)
            if not any(_overlap(box, other, gap) for other in placed):
                break
        else:
            offset = 0.0  # crowded beyond reach: left where it was
            box = (x, y - height, x + width, y)
        offsets[k] = offset
        placed.append(box)
    return offsets


def keep_inside(lefts: np.ndarray, widths: np.ndarray, right: float) -> np.ndarray:
    """Horizontal shifts (N,) in screen pixels (≤ 0: left) that bring labels starting at ``lefts`` and
    ``widths`` wide inside a view whose right edge is at ``right``, so that a label of an object near the
    edge is read whole instead of cut off ("2 Pagrus aura"); a label wider than the room left of it keeps
    its start (never shifted past ``lefts`` = 0 of a label that already starts at the left)."""
    lefts = np.asarray(lefts, dtype=np.float64)
    over = lefts + np.asarray(widths, dtype=np.float64) - right
    return -np.clip(over, 0.0, np.maximum(lefts, 0.0))


def _overlap(a: tuple[float, float, float, float], b: tuple[float, float, float, float], gap: float) -> bool:
    return a[0] < b[2] + gap and b[0] < a[2] + gap and a[1] < b[3] + gap and b[1] < a[3] + gap
