"""A grid of black circles (``diameter`` metres) on white, found by OpenCV's ``findCirclesGrid``.

Symmetric: ``cols`` × ``rows`` circles ``spacing`` metres apart, point (i, j) at (i, j) · spacing.
Asymmetric (OpenCV's pattern): ``rows`` rows ``spacing`` apart, each of ``cols`` circles 2 · spacing apart,
odd rows shifted by one spacing: point (i, j) at ((2 i + j mod 2) · spacing, j · spacing). Ids
``str(j · cols + i)``; board coordinates in OpenCV's convention.

A circle's centre is the centre of its blob in the image; under a tilted view it differs from the
projection of the circle's centre by about f · r² · sin 2θ / (2 Z²) pixels (r its radius, θ the tilt, Z
the distance): small circles are more accurate.

**Point order.** Of the orderings of OpenCV's result, those that would mirror the board are set aside,
and any that does not fit the grid by a homography. An asymmetric grid with an odd number of rows is then
unambiguous; a symmetric grid, or an asymmetric one with an even number of rows, looks the same turned by
half a turn: its description is refused unless it says ``"upright": true`` (the board never turned
beyond a quarter turn in the image; point 0 is then the one from which the board's x runs most nearly
rightwards).
"""

from __future__ import annotations

import cv2
import numpy as np

from usvips.core.calibration_targets import cascade
from usvips.core.calibration_targets.detection import TargetDetection
from usvips.core.calibration_targets.kinds import _board
from usvips.core.calibration_targets.kinds._board import PrintedBoard


class CircleGrid(PrintedBoard):
    kind = "circle-grid"
    description = "circle grid, symmetric or asymmetric (points cols × rows, spacing, diameter)"
    order = 40

    def __init__(self, cols: int, rows: int, spacing: float, diameter: float, asymmetric: bool = False,
                 upright: bool = False, source: str = "") -> None:
        description = {"cols": cols, "rows": rows, "spacing": spacing, "diameter": diameter,
                       "asymmetric": asymmetric, "upright": upright}
        self.cols = _board.count(description, "cols", source, minimum=2)  # one column: OpenCV finds no grid
        self.rows = _board.count(description, "rows", source, minimum=2 if not asymmetric else 3)
        self.spacing = _board.length(description, "spacing", source)
        self.diameter = _board.length(description, "diameter", source)
        self.asymmetric = _board.flag(description, "asymmetric", source)
        self.upright = _board.flag(description, "upright", source)
        nearest = self.spacing * (np.sqrt(2.0) if self.asymmetric else 1.0)
        if self.diameter >= 0.8 * nearest:
            _board.fail(source, "diameter", f"circles of {self.diameter * 1000:g} mm would (nearly) touch: the nearest "
                        f"centres are {nearest * 1000:.4g} mm apart (keep the diameter below 80 % of that)")
        if self.symmetric and not self.upright:
            _board.fail(source, "upright", f"a {'asymmetric' if self.asymmetric else 'symmetric'} circle grid of "
                        f"{self.rows} rows looks the same turned by half a turn, so its point order cannot be "
                        "told; use an asymmetric grid with an odd number of rows, or describe it as upright "
                        "(\"upright\": true in its description): the board never turned beyond a quarter turn")
        flags = cv2.CALIB_CB_ASYMMETRIC_GRID if self.asymmetric else cv2.CALIB_CB_SYMMETRIC_GRID
        self._flags = flags

    @property
    def symmetric(self) -> bool:
        """The grid looks the same turned by half a turn."""
        return not self.asymmetric or self.rows % 2 == 0

    def describe(self) -> dict:
        out = {"kind": self.kind, "cols": self.cols, "rows": self.rows, "spacing": self.spacing,
               "diameter": self.diameter, "asymmetric": self.asymmetric}
        if self.upright:
            out["upright"] = True
        return out

    @classmethod
    def from_description(cls, description: dict, source: str = "") -> CircleGrid:
        _board.unknown_fields(description, {"cols", "rows", "spacing", "diameter", "asymmetric", "upright"}, source)
        get = lambda name: _board.field(description, name, source)  # noqa: E731
        return cls(get("cols"), get("rows"), get("spacing"), get("diameter"), description.get("asymmetric", False),
                   description.get("upright", False), source)

    # ---------------------------------------------------------------------------------- geometry
    def points(self) -> tuple[tuple[str, ...], np.ndarray]:
        j, i = np.mgrid[0:self.rows, 0:self.cols]
        x = (2 * i + j % 2) if self.asymmetric else i
        xy = np.column_stack([x.ravel(), j.ravel()]).astype(np.float64) * self.spacing
        return tuple(str(k) for k in range(len(xy))), xy

    def sheet(self) -> tuple[float, float, float, float]:
        _, xy = self.points()
        margin = self.spacing
        return (-margin, -margin, xy[:, 0].max() + margin, xy[:, 1].max() + margin)

    def ink(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        s = self.spacing
        j = np.clip(np.rint(xy[:, 1] / s), 0, self.rows - 1)
        if self.asymmetric:
            shift = j % 2
            i = np.clip(np.rint((xy[:, 0] / s - shift) / 2), 0, self.cols - 1)
            cx = (2 * i + shift) * s
        else:
            i = np.clip(np.rint(xy[:, 0] / s), 0, self.cols - 1)
            cx = i * s
        inside = (xy[:, 0] - cx) ** 2 + (xy[:, 1] - j * s) ** 2 <= (self.diameter / 2) ** 2
        out = inside.astype(np.float64)
        out[~self._on_sheet(xy)] = np.nan
        return out

    def shapes(self) -> tuple[np.ndarray, np.ndarray]:
        _, xy = self.points()
        return np.empty((0, 4)), np.column_stack([xy, np.full(len(xy), self.diameter / 2)])

    def feature_size(self) -> float:
        return self.diameter

    # ---------------------------------------------------------------------------------- detection
    def stages(self, grey: np.ndarray) -> list[cascade.Stage]:
        """The detectors tried in turn (:mod:`~usvips.core.calibration_targets.cascade`): OpenCV's
        ``findCirclesGrid`` as it comes; with a blob detector that keeps large circles (OpenCV's leaves out
        blobs over 5,000 px); with the grid's points put together by clustering (perspective, clutter near
        the grid)."""
        pattern, count = (self.cols, self.rows), self.cols * self.rows
        parameters = cv2.SimpleBlobDetector_Params()
        parameters.maxArea = max(float(grey.shape[0] * grey.shape[1]) / 8, parameters.minArea + 1)
        large = cv2.SimpleBlobDetector_create(parameters)

        def search(flags: int, detector=None) -> cascade.Search:
            def find(image: np.ndarray) -> np.ndarray | None:
                options = {} if detector is None else {"blobDetector": detector}
                found, centres = cv2.findCirclesGrid(image, pattern, flags=flags, **options)
                return np.asarray(centres).reshape(-1, 2) if found and centres is not None and len(
                    centres) == count else None
            return find

        return [cascade.Stage("findCirclesGrid", search(self._flags)),
                cascade.Stage("findCirclesGrid keeping large circles", search(self._flags, large)),
                cascade.Stage("findCirclesGrid by clustering", search(self._flags | cv2.CALIB_CB_CLUSTERING, large))]

    @_board.guarded
    def detect(self, image: np.ndarray) -> TargetDetection:
        grey = _board.to_grey8(image)
        size = (grey.shape[1], grey.shape[0])
        stages = self.stages(grey)
        result = cascade.run(stages, grey)
        if result is None:
            return TargetDetection.nothing(size, cascade.not_found(
                f"no {self.cols} × {self.rows} {'asymmetric' if self.asymmetric else 'symmetric'} circle grid",
                stages, grey, "every circle must be in view"))
        centres = result.pixels
        grid = np.asarray(centres, np.float64).reshape(self.rows, self.cols, 2)
        ids, model = self.points()
        kept = []
        for candidate in (grid, grid[::-1, ::-1], grid[:, ::-1], grid[::-1, :]):
            pixels = candidate.reshape(-1, 2)
            h, _ = cv2.findHomography(model, pixels, 0)
            if h is None:
                continue
            mapped = cv2.perspectiveTransform(model.reshape(-1, 1, 2), h).reshape(-1, 2)
            fits = np.max(np.linalg.norm(mapped - pixels, axis=1)) < 0.25 * _board.spacing_px(pixels)
            centre = model.mean(axis=0)
            jacobian = np.column_stack([_apply(h, centre + step) - _apply(h, centre) for step in
                                        (np.array([1e-3, 0.0]), np.array([0.0, 1e-3]))])
            if fits and np.linalg.det(jacobian) > 0:
                kept.append(candidate)
        if not kept:
            return TargetDetection.nothing(size, "the circle grid found does not fit the described grid (check "
                                           "cols, rows and asymmetric)")
        notes: tuple[str, ...] = ()
        if len(kept) > 1:
            if not self.upright:
                return TargetDetection.nothing(size, "the circle grid's orientation cannot be told")
            chosen = _board.most_upright(kept)
            if chosen is None:
                return TargetDetection.nothing(size, _board.TURNED_TOO_FAR)
            kept = [chosen]
            notes = (_board.UPRIGHT_NOTE,)
        return _board.finished(grey, ids, kept[0].reshape(-1, 2), cascade.found_note(result) + notes,
                               stage=result.stage.name)


def _apply(h: np.ndarray, xy: np.ndarray) -> np.ndarray:
    p = h @ np.array([xy[0], xy[1], 1.0])
    return p[:2] / p[2]
