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

from usvips.core.calibration_targets import cascade
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
            _board.fail(source, "upright", f"a {self.cols} × {self.rows} chessboard looks the same turned by half a "
                        "turn, so its corner order cannot be told; use a board with odd × even inner corners "
                        "(or ChArUco), or describe it as upright (\"upright\": true in its description): the "
                        "board never turned beyond a quarter turn")

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
    def stages(self, grey: np.ndarray) -> list[cascade.Stage]:
        """The detectors tried in turn on ``grey`` (:mod:`~usvips.core.calibration_targets.cascade`):
        on large frames (:data:`DOWNSCALE_SIDE_PX` or longer) first ``findChessboardCornersSB`` without
        flags on the frame halved (a board that fills a fair part of a 1080p frame is found there in a
        third to a tenth of the time, and ``cornerSubPix`` on the full image brings its corners to within
        a thousandth of a pixel of those found at full size); then at full size OpenCV's
        ``findChessboardCornersSB`` without flags (finds most real boards), with normalisation, on the image
        extended by repeating its edges (a board whose outer squares the image cuts), with an exhaustive
        search; and the classic ``findChessboardCorners`` (adaptive threshold, normalised). Images longer
        than :data:`SEARCH_SIDE_PX` are searched reduced by a whole factor throughout; the corners are
        always refined on the full image. None of them uses ``CALIB_CB_ACCURACY`` (five times slower on a
        1080p frame): ``cornerSubPix`` refines further."""
        pattern, count = (self.cols, self.rows), self.cols * self.rows
        factor = cascade.search_factor(grey, SEARCH_SIDE_PX)

        def sb(flags: int) -> cascade.Search:
            def search(image: np.ndarray) -> np.ndarray | None:
                found, corners = cv2.findChessboardCornersSB(image, pattern, flags=flags)
                return corners.reshape(-1, 2) if found and corners is not None and len(corners) == count else None
            return search

        def classic(image: np.ndarray) -> np.ndarray | None:
            found, corners = cv2.findChessboardCorners(image, pattern, flags=cv2.CALIB_CB_ADAPTIVE_THRESH
                                                       | cv2.CALIB_CB_NORMALIZE_IMAGE)
            return corners.reshape(-1, 2) if found and corners is not None and len(corners) == count else None

        normalise, exhaustive = cv2.CALIB_CB_NORMALIZE_IMAGE, cv2.CALIB_CB_EXHAUSTIVE
        return [cascade.Stage("findChessboardCornersSB on the frame halved", sb(0), 2 * factor,
                              minimum_side=DOWNSCALE_SIDE_PX * factor),
                cascade.Stage("findChessboardCornersSB", sb(0), factor),
                cascade.Stage("findChessboardCornersSB normalised", sb(normalise), factor),
                cascade.Stage("findChessboardCornersSB with the image's edges extended", sb(0), factor,
                              pad=EDGE_PAD_PX),
                cascade.Stage("findChessboardCornersSB exhaustive", sb(normalise | exhaustive), factor),
                cascade.Stage("findChessboardCorners (classic, adaptive threshold)", classic, factor)]

    @_board.guarded
    def detect(self, image: np.ndarray) -> TargetDetection:
        grey = _board.to_grey8(image)
        size = (grey.shape[1], grey.shape[0])
        stages = self.stages(grey)
        found = cascade.run(stages, grey)
        if found is None:
            return TargetDetection.nothing(size, cascade.not_found(
                f"no {self.cols} × {self.rows} chessboard", stages, grey,
                "every inner corner must be in view; cols and rows count inner corners, squares − 1"))
        grid = found.pixels.reshape(self.rows, self.cols, 2)
        candidates = grid_orderings(grid)
        notes = cascade.found_note(found)
        if self.symmetric:
            chosen = _board.most_upright(candidates)
            if chosen is None:
                return TargetDetection.nothing(size, _board.TURNED_TOO_FAR)
            notes += (_board.UPRIGHT_NOTE,)
        else:
            chosen = self._by_square_colours(grey, candidates)
            if chosen is None:
                return TargetDetection.nothing(size, "the chessboard's orientation cannot be told: its black and "
                                               "white squares are not told apart (too dark, too bright or too "
                                               "blurred)")
        ids, _ = self.points()
        return _board.finished(grey, ids, _board.refine_corners(grey, chosen.reshape(-1, 2)), notes,
                               stage=found.stage.name)

    def _by_square_colours(self, grey: np.ndarray, candidates: list[np.ndarray]) -> np.ndarray | None:
        """Of the two orderings of an odd × even board (a half turn apart), the one under which the squares
        seen are coloured as printed (:func:`square_contrast`: every inner square, and every outer square
        inside the image); None when neither stands out."""
        scores = [square_contrast(grey, candidate) for candidate in candidates]
        best = int(np.argmax(scores))
        if not (scores[best] > ORIENTATION_CONTRAST and all(score < 0 for k, score in enumerate(scores)
                                                               if k != best)):
            return None
        return candidates[best]


#: The mean grey-level difference (0–255) between the squares printed white and black that tells a
#: chessboard's orientation: a printed board seen at all shows tens.
ORIENTATION_CONTRAST = 8.0
#: How far (pixels) the image is extended each side for a board whose outer squares it cuts.
EDGE_PAD_PX = 8
#: Images at least this long (pixels, after the search reduction) are searched halved first.
DOWNSCALE_SIDE_PX = 1280


def square_contrast(grey: np.ndarray, grid: np.ndarray) -> float:
    """How well the image's squares match the printed pattern under the ordering ``grid`` (rows, cols, 2)
    of the inner corners: the mean grey level of the squares printed white minus that of those printed
    black (the square diagonally outside corner 0 is black), over every inner square (bounded by four
    found corners) and every outer square (its corners extrapolated by one step) whose centre lies
    inside the image. Positive under the right ordering, its negative under the half-turned one."""
    rows, cols = grid.shape[:2]
    extended = np.empty((rows + 2, cols + 2, 2))
    extended[1:-1, 1:-1] = grid
    extended[1:-1, 0] = 2 * grid[:, 0] - grid[:, 1]
    extended[1:-1, -1] = 2 * grid[:, -1] - grid[:, -2]
    extended[0] = 2 * extended[1] - extended[2]
    extended[-1] = 2 * extended[-2] - extended[-3]
    centres = 0.25 * (extended[:-1, :-1] + extended[:-1, 1:] + extended[1:, :-1] + extended[1:, 1:])
    b, a = np.mgrid[0:rows + 1, 0:cols + 1]
    black = ((a + b) % 2 == 0).ravel()
    centres = centres.reshape(-1, 2)
    half = max(1, int(0.15 * _board.spacing_px(grid.reshape(-1, 2))))
    h, w = grey.shape
    inside = ((centres[:, 0] >= half + 1) & (centres[:, 1] >= half + 1) & (centres[:, 0] <= w - half - 2)
              & (centres[:, 1] <= h - half - 2))
    if not (inside & black).any() or not (inside & ~black).any():
        return -np.inf
    values = np.array([float(cv2.getRectSubPix(grey, (2 * half + 1,) * 2, (float(x), float(y))).mean())
                       for x, y in centres[inside]])
    return float(values[~black[inside]].mean() - values[black[inside]].mean())
