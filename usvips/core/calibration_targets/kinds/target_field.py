"""A 3-D target field: surveyed targets (a calibration frame, a cube) given by a control file — ids and
X, Y, Z in metres — each a white disc with a black cross (``"mark": "cross"``) or a plain disc
(``"disc"``) of ``size`` metres (diameter).

Its coordinates come from a survey, not from a printer: ``exact`` is False (the calibration may search
them for a misprinted coordinate). It cannot be found in an image on its own — its targets all look
alike: the user identifies at least six in a pair and the rest are predicted through the camera model
and snapped (:mod:`usvips.core.calibration_views`); :meth:`TargetField.detect` says so.
"""

from __future__ import annotations

import numpy as np

from usvips.core.calibration_targets.base import CalibrationTarget
from usvips.core.calibration_targets.detection import TargetDetection
from usvips.core.calibration_targets.kinds import _board
from usvips.core.observations import ControlPoints

#: What each target looks like: a white disc with a black cross, or a plain disc.
MARKS = ("cross", "disc")

#: Targets the user identifies in a pair before the rest can be predicted.
MINIMUM_IDENTIFIED = 6


class TargetField(CalibrationTarget):
    kind = "target-field"
    description = "3-D target field from a control file (ids and X, Y, Z in metres; disc or cross targets)"
    order = 50
    exact = False

    def __init__(self, ids, xyz, mark: str = "cross", size: float = 0.03, source: str = "") -> None:
        ids = tuple(str(i) for i in ids)
        xyz = np.asarray(xyz, np.float64).reshape(-1, 3) if len(ids) else np.empty((0, 3))
        if len(ids) < MINIMUM_IDENTIFIED:
            _board.fail(source, "points", f"a target field needs at least {MINIMUM_IDENTIFIED} targets, got {len(ids)}")
        if len(xyz) != len(ids):
            _board.fail(source, "points", f"{len(ids)} ids but {len(xyz)} coordinate rows")
        if not np.all(np.isfinite(xyz)):
            row = int(np.flatnonzero(~np.all(np.isfinite(xyz), axis=1))[0])
            _board.fail(source, "points", f"target {ids[row]!r}: coordinates must be finite")
        duplicates = sorted({i for i in ids if ids.count(i) > 1})
        if duplicates:
            _board.fail(source, "points", f"target id {duplicates[0]!r} is given twice")
        if mark not in MARKS:
            _board.fail(source, "mark", f"must be one of {', '.join(MARKS)}, got {mark!r}")
        self.ids, self.xyz, self.mark = ids, xyz, mark
        self.size = _board.length({"size": size}, "size", source)
        self.source = source
        spread = np.linalg.svd(xyz - xyz.mean(axis=0), compute_uv=False)
        if spread[0] == 0 or spread[1] / spread[0] < 1e-6:
            _board.fail(source, "points", "the targets lie on (nearly) one line: they cannot fix a camera")

    def describe(self) -> dict:
        return {"kind": self.kind, "mark": self.mark, "size": self.size,
                "points": [[pid, *map(float, row)] for pid, row in zip(self.ids, self.xyz, strict=True)]}

    @classmethod
    def from_description(cls, description: dict, source: str = "") -> TargetField:
        _board.unknown_fields(description, {"points", "mark", "size"}, source)
        points = _board.field(description, "points", source)
        if not isinstance(points, list):
            _board.fail(source, "points", "must be a list of [id, X, Y, Z] rows (metres)")
        ids, xyz = [], []
        for k, row in enumerate(points):
            if (not isinstance(row, list) or len(row) != 4 or not isinstance(row[0], (str, int))
                    or isinstance(row[0], bool)
                    or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in row[1:])):
                _board.fail(source, "points", f"row {k + 1}: expected [id, X, Y, Z] (metres), got {row!r}")
            ids.append(str(row[0]))
            xyz.append(row[1:])
        return cls(ids, np.asarray(xyz, np.float64), description.get("mark", "cross"),
                   _board.field(description, "size", source), source)

    def control_points(self) -> ControlPoints:
        return ControlPoints(self.ids, self.xyz, source=self.source or "target field")

    def detect(self, image: np.ndarray) -> TargetDetection:
        grey = _board.to_grey8(image)
        return TargetDetection.nothing((grey.shape[1], grey.shape[0]),
                                       f"identify at least {MINIMUM_IDENTIFIED} targets; the rest are found from them")
