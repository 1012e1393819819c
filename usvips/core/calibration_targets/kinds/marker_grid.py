"""A grid of ArUco or AprilTag markers: ``cols`` × ``rows`` markers of ``marker`` metres, ``separation``
metres apart, ids ``first_id`` … in rows from the top left (OpenCV's ``aruco.GridBoard``), found by OpenCV's
``aruco.ArucoDetector`` with sub-pixel corner refinement.

Points: each marker's four outer corners, id ``"<marker id>-<corner>"``, corner 0 … 3 clockwise from the
marker's top left as printed (OpenCV's order), at OpenCV's board coordinates (marker (c, r) has its top
left at (c, r) · (marker + separation)). A marker names its own corners, so the order is the same in both
cameras and every view by construction. A marker id seen twice in one image (two boards in view) is
dropped and noted.
"""

from __future__ import annotations

import cv2
import numpy as np

from usvips.core.calibration_targets import cascade
from usvips.core.calibration_targets.detection import TargetDetection
from usvips.core.calibration_targets.kinds import _board
from usvips.core.calibration_targets.kinds._board import PrintedBoard


class MarkerGrid(PrintedBoard):
    kind = "marker-grid"
    description = "ArUco/AprilTag marker grid (dictionary, markers cols × rows, marker size, separation)"
    order = 30

    def __init__(self, dictionary: str, cols: int, rows: int, marker: float, separation: float, first_id: int = 0,
                 source: str = "") -> None:
        description = {"dictionary": dictionary, "cols": cols, "rows": rows, "marker": marker,
                       "separation": separation, "first_id": first_id}
        self.dictionary_name, self.dictionary = _board.dictionary(description, "dictionary", source)
        self.cols = _board.count(description, "cols", source, minimum=1)
        self.rows = _board.count(description, "rows", source, minimum=1)
        if self.cols * self.rows < 2:
            _board.fail(source, "cols", "a marker grid needs at least 2 markers")
        self.marker = _board.length(description, "marker", source)
        self.separation = _board.length(description, "separation", source)
        self.first_id = _board.count(description, "first_id", source, minimum=0)
        available = len(self.dictionary.bytesList)
        if self.first_id + self.cols * self.rows > available:
            _board.fail(source, "dictionary", f"{self.dictionary_name} has {available} markers; a {self.cols} × "
                        f"{self.rows} grid from id {self.first_id} needs {self.first_id + self.cols * self.rows}")
        ids = np.arange(self.first_id, self.first_id + self.cols * self.rows, dtype=np.int32)
        self.board = cv2.aruco.GridBoard((self.cols, self.rows), self.marker, self.separation, self.dictionary, ids)
        parameters = cv2.aruco.DetectorParameters()
        parameters.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
        # the refinement window as half a module (OpenCV's default, 0.3, leaves ~0.3 px of rounding bias
        # at a blurred marker corner; a whole module reaches the marker's inner bits)
        parameters.cornerRefinementWinSize = 8
        parameters.relativeCornerRefinmentWinSize = 0.5
        self.detector = cv2.aruco.ArucoDetector(self.dictionary, parameters)

    def describe(self) -> dict:
        out = {"kind": self.kind, "dictionary": self.dictionary_name, "cols": self.cols, "rows": self.rows,
               "marker": self.marker, "separation": self.separation}
        if self.first_id:
            out["first_id"] = self.first_id
        return out

    @classmethod
    def from_description(cls, description: dict, source: str = "") -> MarkerGrid:
        _board.unknown_fields(description, {"dictionary", "cols", "rows", "marker", "separation", "first_id"},
                              source)
        get = lambda name: _board.field(description, name, source)  # noqa: E731
        return cls(get("dictionary"), get("cols"), get("rows"), get("marker"), get("separation"),
                   description.get("first_id", 0), source)

    # ---------------------------------------------------------------------------------- geometry
    def _corners(self) -> np.ndarray:
        return np.asarray(self.board.getObjPoints(), np.float64)[:, :, :2]

    def _ids(self) -> np.ndarray:
        return np.asarray(self.board.getIds()).ravel()

    def points(self) -> tuple[tuple[str, ...], np.ndarray]:
        ids = tuple(f"{marker}-{corner}" for marker in self._ids() for corner in range(4))
        return ids, self._corners().reshape(-1, 2)

    def sheet(self) -> tuple[float, float, float, float]:
        margin = max(self.separation, self.marker / 4)
        pitch = self.marker + self.separation
        return (-margin, -margin, self.cols * pitch - self.separation + margin,
                self.rows * pitch - self.separation + margin)

    def _bits(self) -> np.ndarray:
        return _board.marker_bits(self.dictionary, self._ids())

    def ink(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        cells = np.arange(self.cols * self.rows).reshape(self.rows, self.cols)
        out = _board.lattice_marker_ink(xy, (0.0, 0.0), self.marker + self.separation, self.marker, cells,
                                        self._bits())
        out[np.isnan(out)] = 0.0
        out[~self._on_sheet(xy)] = np.nan
        return out

    def shapes(self) -> tuple[np.ndarray, np.ndarray]:
        return _board.marker_rectangles(self._corners()[:, 0], self.marker, self._bits()), np.empty((0, 3))

    def feature_size(self) -> float:
        return self.marker / (self.dictionary.markerSize + 2)

    def _misplaced(self, point_ids: tuple[str, ...], pixels: np.ndarray) -> bool:
        """The markers found do not lie as on the board: a homography from the board cannot put their corners
        within a fifth of a marker of where they are found (a flipped image — some codes read the same
        mirrored —, or another board with the same ids). One marker alone cannot tell."""
        if len(point_ids) < 8:
            return False
        ids, xy = self.points()
        index = {pid: k for k, pid in enumerate(ids)}
        model = xy[[index[pid] for pid in point_ids]]
        h, _ = cv2.findHomography(model, pixels, 0)
        if h is None:
            return True
        mapped = cv2.perspectiveTransform(model.reshape(-1, 1, 2), h).reshape(-1, 2)
        quads = pixels.reshape(-1, 4, 2)
        side = float(np.mean(np.linalg.norm(quads - np.roll(quads, 1, axis=1), axis=2)))
        return bool(np.max(np.linalg.norm(mapped - pixels, axis=1)) > 0.2 * side)

    # ---------------------------------------------------------------------------------- detection
    def stages(self, grey: np.ndarray) -> list[cascade.Stage]:
        """The detectors tried in turn (:mod:`~usvips.core.calibration_targets.cascade`): OpenCV's
        ``ArucoDetector`` as set up; then with thresholds over a wider range of windows and smaller markers
        allowed (:func:`~._board.widen_marker_search`); then, for large frames, on the frame halved (the
        corners refined again at full size). Any of the grid's markers found is a success: a grid seen in
        part gives the markers seen."""
        known = set(int(k) for k in self._ids())
        return [cascade.Stage("ArucoDetector", self._search(self.detector, known)),
                cascade.Stage("ArucoDetector with a wider marker search", self._search(self._wide_detector(), known)),
                cascade.Stage("ArucoDetector on the frame halved", self._search(self.detector, known), 2,
                              minimum_side=_board.DOWNSCALE_SIDE_PX)]

    def _wide_detector(self) -> cv2.aruco.ArucoDetector:
        parameters = self.detector.getDetectorParameters()
        _board.widen_marker_search(parameters)
        return cv2.aruco.ArucoDetector(self.dictionary, parameters)

    @staticmethod
    def _search(detector: cv2.aruco.ArucoDetector, known: set[int]) -> cascade.Search:
        def search(image: np.ndarray):
            corners, ids, _ = detector.detectMarkers(image)
            found = [] if ids is None else [int(k) for k in np.asarray(ids).ravel()]
            if not any(k in known for k in found):
                return None
            return np.vstack([np.asarray(c, np.float64).reshape(4, 2) for c in corners]), found
        return search

    @_board.guarded
    def detect(self, image: np.ndarray) -> TargetDetection:
        grey = _board.to_grey8(image)
        size = (grey.shape[1], grey.shape[0])
        known = set(int(k) for k in self._ids())
        stages = self.stages(grey)
        result = cascade.run(stages, grey)
        if result is None:
            return TargetDetection.nothing(size, cascade.not_found(
                f"no marker of the {self.cols} × {self.rows} {self.dictionary_name} grid (ids {min(known)}–"
                f"{max(known)})", stages, grey, "a marker is found when its whole square, with its black border, "
                "is in view"))
        found = list(result.extra)
        corners = result.pixels.reshape(-1, 4, 2)
        if result.stage.factor > 1:
            corners = self._refined(grey, corners)
        counts = {k: found.count(k) for k in found}
        notes = tuple(f"marker {k} seen {n} times: dropped" for k, n in sorted(counts.items()) if n > 1 and k in known)
        keep = sorted((i for i, k in enumerate(found) if k in known and counts[k] == 1), key=lambda i: found[i])
        point_ids = tuple(f"{found[i]}-{corner}" for i in keep for corner in range(4))
        pixels = corners[keep].reshape(-1, 2)
        if self._misplaced(point_ids, pixels):
            return TargetDetection.nothing(size, "the markers found do not lie as on the board: a flipped "
                                           "(mirrored) image, or another board with the same marker ids in view")
        return _board.finished(grey, point_ids, pixels, notes + cascade.found_note(result), stage=result.stage.name)

    def _refined(self, grey: np.ndarray, corners: np.ndarray) -> np.ndarray:
        """Marker corners found in a reduced image, refined on the full image as the detector refines them
        (``cornerSubPix`` over half a module)."""
        side = float(np.median(np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)))
        half = int(np.clip(round(0.5 * side / (self.dictionary.markerSize + 2)), 2, 12))
        criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01)
        points = np.ascontiguousarray(corners.reshape(-1, 1, 2), np.float32)
        return cv2.cornerSubPix(grey, points, (half, half), (-1, -1), criteria).reshape(-1, 4, 2).astype(np.float64)
