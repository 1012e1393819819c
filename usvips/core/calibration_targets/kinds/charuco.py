"""A ChArUco board: a chessboard of ``cols`` × ``rows`` squares (``square`` metres) with an ArUco marker
(``marker`` metres, from ``dictionary``) in each white square, found by OpenCV's ``aruco.CharucoDetector``.

Points: OpenCV's ChArUco corners — the inner chessboard corners, id ``str(k)`` for OpenCV's corner id
k, at OpenCV's board coordinates ((i + 1) · square, (j + 1) · square, 0) for corner k = j · (cols − 1) + i.
Their order is fixed by construction (each corner is named by the markers around it), so it is the same
in both cameras and every view, whatever the board's orientation. ``legacy`` selects OpenCV's pattern
before 4.6 (for boards with an even number of rows printed by older software: which squares are black).
"""

from __future__ import annotations

import cv2
import numpy as np

from usvips.core.calibration_targets import cascade
from usvips.core.calibration_targets.detection import TargetDetection
from usvips.core.calibration_targets.kinds import _board
from usvips.core.calibration_targets.kinds._board import PrintedBoard


class CharucoBoard(PrintedBoard):
    kind = "charuco"
    description = "ChArUco board (dictionary, squares cols × rows, square and marker size)"
    order = 20

    def __init__(self, dictionary: str, cols: int, rows: int, square: float, marker: float, legacy: bool = False,
                 source: str = "") -> None:
        description = {"dictionary": dictionary, "cols": cols, "rows": rows, "square": square, "marker": marker,
                       "legacy": legacy}
        self.dictionary_name, self.dictionary = _board.dictionary(description, "dictionary", source)
        self.cols = _board.count(description, "cols", source, minimum=3)
        self.rows = _board.count(description, "rows", source, minimum=3)
        self.square = _board.length(description, "square", source)
        self.marker = _board.length(description, "marker", source)
        self.legacy = _board.flag(description, "legacy", source)
        if self.marker >= self.square:
            _board.fail(source, "marker", f"the marker ({self.marker * 1000:g} mm) must be smaller than the square "
                        f"({self.square * 1000:g} mm)")
        needed = self.cols * self.rows // 2
        available = len(self.dictionary.bytesList)
        if needed > available:
            _board.fail(source, "dictionary", f"{self.dictionary_name} has {available} markers; a {self.cols} × "
                        f"{self.rows} board needs {needed}")
        self.board = cv2.aruco.CharucoBoard((self.cols, self.rows), self.square, self.marker, self.dictionary)
        self.board.setLegacyPattern(self.legacy)
        parameters = cv2.aruco.DetectorParameters()
        parameters.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE
        charuco = cv2.aruco.CharucoParameters()
        charuco.minMarkers = 2
        self.detector = cv2.aruco.CharucoDetector(self.board, charuco, parameters)

    def describe(self) -> dict:
        out = {"kind": self.kind, "dictionary": self.dictionary_name, "cols": self.cols, "rows": self.rows,
               "square": self.square, "marker": self.marker}
        if self.legacy:
            out["legacy"] = True
        return out

    @classmethod
    def from_description(cls, description: dict, source: str = "") -> CharucoBoard:
        _board.unknown_fields(description, {"dictionary", "cols", "rows", "square", "marker", "legacy"}, source)
        get = lambda name: _board.field(description, name, source)  # noqa: E731
        return cls(get("dictionary"), get("cols"), get("rows"), get("square"), get("marker"),
                   description.get("legacy", False), source)

    # ---------------------------------------------------------------------------------- geometry
    def points(self) -> tuple[tuple[str, ...], np.ndarray]:
        xy = np.asarray(self.board.getChessboardCorners(), np.float64).reshape(-1, 3)[:, :2]
        return tuple(str(k) for k in range(len(xy))), xy

    def sheet(self) -> tuple[float, float, float, float]:
        margin = 0.5 * self.square
        return (-margin, -margin, self.cols * self.square + margin, self.rows * self.square + margin)

    def _black_squares(self) -> np.ndarray:
        """(rows, cols) True where the printed square is black (OpenCV's pattern, legacy or not)."""
        b, a = np.mgrid[0:self.rows, 0:self.cols]
        black = (a + b) % 2 == 0
        if self.legacy and self.rows % 2 == 0:
            black = ~black
        return black

    def _markers(self) -> tuple[np.ndarray, np.ndarray]:
        """Top-left corners (N, 2) and printed modules of the board's markers."""
        corners = np.asarray(self.board.getObjPoints(), np.float64)[:, 0, :2]
        return corners, _board.marker_bits(self.dictionary, np.asarray(self.board.getIds()).ravel())

    def ink(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        a = np.floor(xy[:, 0] / self.square).astype(np.int64)
        b = np.floor(xy[:, 1] / self.square).astype(np.int64)
        inside = (a >= 0) & (a < self.cols) & (b >= 0) & (b < self.rows)
        out = np.zeros(len(xy))
        out[inside] = self._black_squares()[b[inside], a[inside]]
        corners, bits = self._markers()
        cells = np.full((self.rows, self.cols), -1)
        cell = np.floor((corners + 0.5 * (self.square - self.marker)) / self.square + 1e-9).astype(np.int64)
        cells[cell[:, 1], cell[:, 0]] = np.arange(len(corners))
        offset = 0.5 * (self.square - self.marker)
        marker = _board.lattice_marker_ink(xy - offset, (0.0, 0.0), self.square, self.marker, cells, bits)
        out = np.where(np.isfinite(marker), marker, out)
        out[~self._on_sheet(xy)] = np.nan
        return out

    def shapes(self) -> tuple[np.ndarray, np.ndarray]:
        b, a = np.nonzero(self._black_squares())
        squares = np.column_stack([a, b, a + 1, b + 1]) * self.square
        corners, bits = self._markers()
        return np.vstack([squares, _board.marker_rectangles(corners, self.marker, bits)]), np.empty((0, 3))

    def feature_size(self) -> float:
        return self.marker / (self.dictionary.markerSize + 2)

    # ---------------------------------------------------------------------------------- detection
    def stages(self, grey: np.ndarray, seen: list[int] | None = None) -> list[cascade.Stage]:
        """The detectors tried in turn (:mod:`~usvips.core.calibration_targets.cascade`): OpenCV's
        ``CharucoDetector`` as set up; then with markers' thresholds searched over a wider range of window
        sizes and smaller markers allowed (uneven light, a small board in a large frame); then, for large
        frames, on the frame halved (the corners refined at full size). A board seen in part gives the
        corners seen. ``seen`` (a list) receives the number of the board's markers each stage saw."""
        seen = [] if seen is None else seen
        return [cascade.Stage("CharucoDetector", self._search(self.detector, seen)),
                cascade.Stage("CharucoDetector with a wider marker search", self._search(self._wide_detector(), seen)),
                cascade.Stage("CharucoDetector on the frame halved", self._search(self.detector, seen), 2,
                              minimum_side=_board.DOWNSCALE_SIDE_PX)]

    def _wide_detector(self) -> cv2.aruco.CharucoDetector:
        parameters = cv2.aruco.DetectorParameters()
        parameters.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE
        _board.widen_marker_search(parameters)
        charuco = cv2.aruco.CharucoParameters()
        charuco.minMarkers = 2
        return cv2.aruco.CharucoDetector(self.board, charuco, parameters)

    @staticmethod
    def _search(detector: cv2.aruco.CharucoDetector, seen: list[int]) -> cascade.Search:
        def search(image: np.ndarray):
            corners, ids, _, marker_ids = detector.detectBoard(image)
            seen.append(0 if marker_ids is None else len(marker_ids))
            if ids is None or len(ids) == 0:
                return None
            return np.asarray(corners, np.float64).reshape(-1, 2), np.asarray(ids).ravel()
        return search

    @_board.guarded
    def detect(self, image: np.ndarray) -> TargetDetection:
        grey = _board.to_grey8(image)
        size = (grey.shape[1], grey.shape[0])
        markers: list[int] = []
        stages = self.stages(grey, markers)
        found = cascade.run(stages, grey)
        if found is None:
            seen = max(markers, default=0)
            if seen >= 3:
                return TargetDetection.nothing(size, cascade.not_found(
                    f"{seen} {self.dictionary_name} markers seen but no ChArUco corner", stages, grey,
                    f"check the squares, cols × rows ({self.cols} × {self.rows}), and legacy (a board with an even "
                    "number of rows printed by OpenCV before 4.6)"))
            return TargetDetection.nothing(size, cascade.not_found(
                "no ChArUco corner", stages, grey, f"{seen} {self.dictionary_name} markers of the board seen; a "
                "corner needs its two neighbouring markers in view"))
        ids = np.asarray(found.extra).ravel()
        pixels = found.pixels
        if found.stage.factor > 1:
            pixels = _board.refine_corners(grey, pixels)
        order = np.argsort(ids, kind="stable")
        return _board.finished(grey, tuple(str(int(k)) for k in ids[order]), pixels[order],
                               cascade.found_note(found), stage=found.stage.name)
