"""The stored objects' outlines on one image pair, held as flat numpy arrays so that a pane can draw a
survey of 100,000 of them at a bounded cost (the panes' level of detail, issue 37).

Pixels are USVIPS pixels (x right, y down, origin at the centre of the top-left pixel). An outline is the
polyline of its points on each image (column pairs ``LEFT`` and ``RIGHT`` of :attr:`OutlineSet.points`),
back to its first point when it closes. The set answers what a pane asks of it without a Python loop over
the objects: which outlines meet a rectangle (:meth:`OutlineSet.in_rect`), their NaN-separated polyline
(:meth:`OutlineSet.lines`), and every outline drawn into one raster at (at most) image resolution
(:func:`raster`, the cheap form shown when too many outlines are in view to stroke them one by one).
"""

from __future__ import annotations

import cv2
import numpy as np

#: column of :attr:`OutlineSet.points` where each side's (x, y) start
SIDE_COLUMNS = {0: 0, 1: 2}
#: bits of sub-pixel precision handed to OpenCV's line drawing
_SHIFT = 4


class OutlineSet:
    """Outlines by object id; ``version`` grows with every change (a pane's raster of an older version is
    stale). Every outline has the same number of points on both images (one per pick, or per point of a
    projected circle)."""

    def __init__(self) -> None:
        self.ids = np.zeros(0, np.int64)
        self.counts = np.zeros(0, np.int64)  # points per outline, the closing point included
        self.points = np.zeros((0, 4))  # xl, yl, xr, yr (pixels)
        self.version = 0
        #: the version after the last change that dropped an outline (since it, outlines were only added)
        self.dropped_at = 0
        self._starts: np.ndarray | None = None
        self._boxes: dict[int, np.ndarray] = {}

    def __len__(self) -> int:
        return len(self.ids)

    def __iter__(self):
        """The ids (int) of the outlines held."""
        return iter(self.ids.tolist())

    def __contains__(self, object_id: object) -> bool:
        return bool(np.any(self.ids == object_id))

    # ------------------------------------------------------------------ changes
    def put(self, ids: np.ndarray, counts: np.ndarray, closed: np.ndarray, points: np.ndarray) -> None:
        """Set the outlines of ``ids`` (replacing any they had): ``counts[k]`` rows of ``points`` (P, 4:
        xl, yl, xr, yr pixels) in order belong to ``ids[k]``; a ``closed`` one goes back to its first point."""
        ids = np.asarray(ids, np.int64).reshape(-1)
        counts = np.asarray(counts, np.int64).reshape(-1)
        closed = np.asarray(closed, bool).reshape(-1) & (counts > 2)
        points = np.asarray(points, float).reshape(-1, 4)
        if not (len(ids) == len(counts) == len(closed)) or counts.sum() != len(points) or np.any(counts < 1):
            raise ValueError("outlines: ids, counts, closed flags and points do not match")
        self.drop(ids)
        if not len(ids):
            return
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        full = counts + closed
        order = _ranges(starts, counts, full)
        self.ids = np.concatenate([self.ids, ids])
        self.counts = np.concatenate([self.counts, full])
        self.points = np.concatenate([self.points, points[order]])
        self._changed()

    def drop(self, ids) -> None:
        """Forget the outlines of ``ids`` (those it has)."""
        gone = np.isin(self.ids, np.asarray(ids, np.int64).reshape(-1))
        if not gone.any():
            return
        self.points = self.points[~np.repeat(gone, self.counts)]
        self.ids, self.counts = self.ids[~gone], self.counts[~gone]
        self._changed()
        self.dropped_at = self.version

    def clear(self) -> None:
        self.drop(self.ids)

    def copy(self) -> OutlineSet:
        """A set holding the same outlines, unchanged by later changes of this one (its arrays are never
        written in place, so they are shared): what a worker thread reads."""
        other = OutlineSet()
        other.ids, other.counts, other.points, other.version = self.ids, self.counts, self.points, self.version
        other.dropped_at = self.dropped_at
        return other

    def added_since(self, version: int, count: int) -> np.ndarray | None:
        """Indices of the outlines added since ``version``, when the set then held ``count`` outlines and none
        has been dropped or replaced since (new ones go at the end); None when one has."""
        if self.dropped_at > version or count > len(self.ids):
            return None
        return np.arange(count, len(self.ids))

    def _changed(self) -> None:
        self.version += 1
        self._starts = None
        self._boxes = {}

    # ------------------------------------------------------------------ questions
    def starts(self) -> np.ndarray:
        """Index in :attr:`points` of each outline's first point."""
        if self._starts is None:
            self._starts = np.concatenate([[0], np.cumsum(self.counts)[:-1]]).astype(np.int64)
        return self._starts

    def side_points(self, side: int) -> np.ndarray:
        """Every outline point on image ``side`` (0 left, 1 right), (P, 2) pixels."""
        column = SIDE_COLUMNS[side]
        return self.points[:, column:column + 2]

    def boxes(self, side: int) -> np.ndarray:
        """Each outline's bounding box on image ``side``: (N, 4) min x, min y, max x, max y (pixels)."""
        if side not in self._boxes:
            xy = self.side_points(side)
            if not len(self.ids):
                self._boxes[side] = np.zeros((0, 4))
            else:
                starts = self.starts()
                self._boxes[side] = np.column_stack([np.minimum.reduceat(xy, starts, axis=0),
                                                     np.maximum.reduceat(xy, starts, axis=0)])
        return self._boxes[side]

    def in_rect(self, side: int, left: float, top: float, right: float, bottom: float) -> np.ndarray:
        """Indices (into :attr:`ids`) of the outlines whose bounding box meets the rectangle (pixels)."""
        box = self.boxes(side)
        meets = (box[:, 0] <= right) & (box[:, 2] >= left) & (box[:, 1] <= bottom) & (box[:, 3] >= top)
        return np.flatnonzero(meets)

    def outline(self, object_id: int, side: int) -> np.ndarray | None:
        """One object's outline on image ``side`` (n, 2) pixels; None when the set has none for it."""
        where = np.flatnonzero(self.ids == object_id)
        if not len(where):
            return None
        start = self.starts()[where[0]]
        return self.side_points(side)[start:start + self.counts[where[0]]]

    def lines(self, side: int, indices: np.ndarray | None = None) -> np.ndarray:
        """The outlines at ``indices`` (all by default) on image ``side`` as one polyline (K, 2) pixels,
        each outline ended by a NaN row (the separator)."""
        if indices is None:
            indices = np.arange(len(self.ids))
        indices = np.asarray(indices, np.int64)
        counts = self.counts[indices]
        gather = _ranges(self.starts()[indices], counts, counts)
        out = np.full((len(gather) + len(indices), 2), np.nan)
        slots = np.arange(len(gather)) + np.repeat(np.arange(len(indices)), counts)
        out[slots] = self.side_points(side)[gather]
        return out


def _ranges(starts: np.ndarray, counts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Indices ``starts[k] + (0, 1, ..., counts[k] - 1)`` for each k, then back to ``starts[k]`` for the
    ``lengths[k] - counts[k]`` (0 or 1) closing point; concatenated."""
    lengths = np.asarray(lengths, np.int64)
    if not len(lengths):
        return np.zeros(0, np.int64)
    firsts = np.cumsum(lengths) - lengths
    step = np.arange(lengths.sum()) - np.repeat(firsts, lengths)
    step = np.where(step >= np.repeat(counts, lengths), 0, step)  # the closing point: the first again
    return np.repeat(starts, lengths) + step


def raster_scale(width: int, height: int, max_side: int) -> float:
    """Raster pixels per image pixel for an image of ``width`` × ``height``: 1, or less so that the raster's
    longer side is at most ``max_side``."""
    return min(1.0, max_side / max(width, height, 1))


def raster(outlines: OutlineSet, side: int, width: int, height: int, max_side: int) -> np.ndarray:
    """Every outline of ``outlines`` on image ``side`` drawn 1 raster pixel wide into a mask (uint8, 255 on
    a line) of the image's size times :func:`raster_scale`: raster pixel (i, j) covers image pixels
    x ∈ [i / s − ½, (i + 1) / s − ½) (and likewise y). Outlines are grouped by their number of points so
    that no Python loop runs over them (OpenCV draws them, its own threads, the GIL released)."""
    scale = raster_scale(width, height, max_side)
    mask = np.zeros((max(1, round(height * scale)), max(1, round(width * scale))), np.uint8)
    if not len(outlines):
        return mask
    xy = outlines.side_points(side)
    fixed = np.round(((xy + 0.5) * scale - 0.5) * (1 << _SHIFT))
    fixed = np.clip(np.nan_to_num(fixed), -(2 ** 30), 2 ** 30).astype(np.int32)
    starts, counts = outlines.starts(), outlines.counts
    for count in np.unique(counts):
        chosen = starts[counts == count]
        paths = fixed[chosen[:, None] + np.arange(count)]  # (n, count, 2)
        cv2.polylines(mask, list(paths), False, 255, 1, cv2.LINE_8, _SHIFT)
    return mask
