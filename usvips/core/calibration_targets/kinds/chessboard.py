"""A plain chessboard: ``cols`` × ``rows`` inner corners (squares − 1 each way), squares of ``square``
metres, found by OpenCV's ``findChessboardCornersSB`` and refined by ``cornerSubPix``.

Points: inner corner (i, j), i = 0 … cols − 1 along the board's x, j = 0 … rows − 1 along y, has id
``str(j · cols + i)`` and board coordinates (i · square, j · square, 0) — OpenCV's convention. The printed
board has (cols + 1) × (rows + 1) squares; the square diagonally outside corner 0 is black.

**Corner order.** OpenCV returns the corners in one of the grid's orderings. Those that would mirror the
board are set aside (a camera sees the board's front: the board's x and y turn the same way as the
image's). What is left differs by a half turn, which only an odd × even board tells apart: its corner-0
square is black and its opposite corner's white, and that is checked in the image. A board with odd × odd
or even × even inner corners (or a square one) looks the same turned by half a turn: its description is
refused unless it says ``"upright": true`` — the rule that the board is never turned by more than a quarter
turn in the image (corner 0 is then the one from which the board's x runs most nearly rightwards; a view
where another order runs nearly as rightwards is refused, :data:`~._board.UPRIGHT_MARGIN`).
"""

from __future__ import annotations

import cv2
import numpy as np

from usvips.core.calibration_targets.detection import TargetDetection
from usvips.core.calibration_targets.kinds import _board
from usvips.core.calibration_targets.kinds._board import PrintedBoard

#: Images larger than this (pixels, the longer side) are searched reduced by a whole factor (a 12 MP still
#: in about a second, not four); the corners are then refined on the full image.
SEARCH_SIDE_PX = 2560


def grid_orderings(grid: np.ndarray) -> list[np.ndarray]:
    """The orderings of a found (rows, cols, 2) grid of pixels that do not mirror the board: those whose
    x step turned by a quarter turn clockwise in the image (y down) gives the y step."""
    candidates = [grid, grid[::-1, ::-1], grid[:, ::-1], grid[::-1, :]]
    if grid.shape[0] == grid.shape[1]:
        candidates += [np.transpose(c, (1, 0, 2)) for c in candidates]
    kept = []
    for candidate in candidates:
        dx = (candidate[:, 1:] - candidate[:, :-1]).reshape(-1, 2).mean(axis=0)
        dy = (candidate[1:] - candidate[:-1]).reshape(-1, 2).mean(axis=0)
        if dx[0] * dy[1] - dx[1] * dy[0] > 0:
            kept.append(candidate)
    return kept


def refine_corners(grey: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """OpenCV's ``cornerSubPix`` on chessboard corners, over a window of 0.35 × the corner spacing each
    side (on boards rendered through every housing: about 0.04 px RMS, where findChessboardCornersSB's own
    accuracy refinement gives about 0.12 px and costs five times its search)."""
    half = int(np.clip(round(0.35 * _board.spacing_px(pixels)), 2, 25))
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 40, 0.001)
    refined = cv2.cornerSubPix(grey, np.ascontiguousarray(pixels, np.float32).reshape(-1, 1, 2), (half, half),
                               (-1, -1), criteria)
    return refined.reshape(-1, 2).astype(np.float64)


class Chessboard(PrintedBoard):
    kind = "chessboard"
    description = "plain chessboard (inner corners cols × rows, square size)"
    order = 10

    def __init__(self, cols: int, rows: int, square: float, upright: bool = False, source: str = "") -> None:
        description = {"cols": cols, "rows": rows, "square": square, "upright": upright}
        self.cols = _board.count(description, "cols", source)
        self.rows = _board.count(description, "rows", source)
        self.square = _board.length(description, "square", source)
        self.upright = _board.flag(description, "upright", source)
        if self.symmetric and not self.upright:
            _board.fail(source, "cols", f"a {self.cols} × {self.rows} chessboard looks the same turned by half a "
                        "turn, so its corner order cannot be told; use a board with odd × even inner corners "
                        "(or ChArUco), or describe it as upright (--upright; \"upright\": true in the file): the board "
                        "never turned beyond a quarter turn")

    @property
    def symmetric(self) -> bool:
        """The board looks the same turned by half a turn (inner corners odd × odd or even × even)."""
        return (self.cols + self.rows) % 2 == 0

    def describe(self) -> dict:
        out = {"kind": self.kind, "cols": self.cols, "rows": self.rows, "square": self.square}
        if self.upright:
            out["upright"] = True
        return out

    @classmethod
    def from_description(cls, description: dict, source: str = "") -> Chessboard:
        _board.unknown_fields(description, {"cols", "rows", "square", "upright"}, source)
        return cls(_board.field(description, "cols", source), _board.field(description, "rows", source),
                   _board.field(description, "square", source), description.get("upright", False), source)

    # ---------------------------------------------------------------------------------- geometry
    def points(self) -> tuple[tuple[str, ...], np.ndarray]:
        j, i = np.mgrid[0:self.rows, 0:self.cols]
        xy = np.column_stack([i.ravel(), j.ravel()]) * self.square
        return tuple(str(k) for k in range(len(xy))), xy.astype(np.float64)

    def sheet(self) -> tuple[float, float, float, float]:
        s = self.square
        return (-2 * s, -2 * s, (self.cols + 1) * s, (self.rows + 1) * s)

    def ink(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        a = np.floor(xy[:, 0] / self.square).astype(np.int64) + 1
        b = np.floor(xy[:, 1] / self.square).astype(np.int64) + 1
        squares = (a >= 0) & (a <= self.cols) & (b >= 0) & (b <= self.rows)
        out = np.where(squares & ((a + b) % 2 == 0), 1.0, 0.0)
        out[~self._on_sheet(xy)] = np.nan
        return out

    def shapes(self) -> tuple[np.ndarray, np.ndarray]:
        s = self.square
        b, a = np.mgrid[0:self.rows + 1, 0:self.cols + 1]
        black = (a + b) % 2 == 0
        x0, y0 = (a[black] - 1) * s, (b[black] - 1) * s
        return np.column_stack([x0, y0, x0 + s, y0 + s]), np.empty((0, 3))

    def feature_size(self) -> float:
        return self.square

    # ---------------------------------------------------------------------------------- detection
    @_board.guarded
    def detect(self, image: np.ndarray) -> TargetDetection:
        grey = _board.to_grey8(image)
        size = (grey.shape[1], grey.shape[0])
        # without CALIB_CB_ACCURACY (five times slower on a 1080p frame, ~1 s): cornerSubPix refines further
        flags = cv2.CALIB_CB_NORMALIZE_IMAGE
        height, width = grey.shape
        factor = int(np.ceil(max(height, width) / SEARCH_SIDE_PX))
        search = grey if factor == 1 else cv2.resize(grey, (width // factor, height // factor),
                                                     interpolation=cv2.INTER_AREA)
        found, corners = cv2.findChessboardCornersSB(search, (self.cols, self.rows), flags=flags)
        if not found or corners is None or len(corners) != self.cols * self.rows:
            return TargetDetection.nothing(size, f"no {self.cols} × {self.rows} chessboard found (every inner "
                                           "corner must be in view; cols and rows count inner corners, "
                                           "squares − 1)")
        if factor > 1:  # a pixel of the reduced image averages factor × factor pixels: centre to centre
            corners = (corners.astype(np.float64) + 0.5) * factor - 0.5
        grid = corners.reshape(self.rows, self.cols, 2).astype(np.float64)
        candidates = grid_orderings(grid)
        notes: tuple[str, ...] = ()
        if self.symmetric:
            chosen = _board.most_upright(candidates)
            if chosen is None:
                return TargetDetection.nothing(size, _board.TURNED_TOO_FAR)
            notes = (_board.UPRIGHT_NOTE,)
        else:
            scores = [self._origin_contrast(grey, c) for c in candidates]
            best = int(np.argmax(scores))
            if not (scores[best] > 8 and all(score < 0 for k, score in enumerate(scores) if k != best)):
                return TargetDetection.nothing(size, "the chessboard's orientation cannot be told: the squares "
                                               "at its corners are not seen clearly (keep the whole board, with "
                                               "its outer squares, in view)")
            chosen = candidates[best]
        ids, _ = self.points()
        return _board.finished(grey, ids, refine_corners(grey, chosen.reshape(-1, 2)), notes)

    @staticmethod
    def _origin_contrast(grey: np.ndarray, grid: np.ndarray) -> float:
        """Grey level of the square beside corner 0 along x (white when this ordering is right) minus that
        of the square diagonally outside corner 0 (black when right); NaN-safe: −inf off the image."""
        c0 = grid[0, 0]
        dx, dy = grid[0, 1] - c0, grid[1, 0] - c0
        probes = np.array([c0 + 0.5 * (dx - dy), c0 - 0.5 * (dx + dy)])
        h, w = grey.shape
        if np.any(probes < 1) or np.any(probes[:, 0] > w - 2) or np.any(probes[:, 1] > h - 2):
            return -np.inf
        radius = max(1.0, 0.15 * min(np.linalg.norm(dx), np.linalg.norm(dy)))
        values = [float(cv2.getRectSubPix(grey, (2 * int(radius) + 1,) * 2, tuple(map(float, p))).mean())
                  for p in probes]
        return values[0] - values[1]
