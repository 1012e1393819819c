"""Plausibility of a measured object's geometry, for the quality rules: facts a correct measurement rarely
shows, which a wrong match (a conjugate on the wrong peak of the epipolar curve) produces while every
precision rule passes.

A wrong conjugate moves a vertex along the LEFT camera's ray (its depth changes, its image position does
not): the measured length then leans out of the image plane towards the line of sight. A fish a survey
measures swims across the view, not at the camera — protocols keep lengths of fish that are roughly side on
(Harvey et al. 2002, 2004; Langlois et al. 2020 measure fish "perpendicular to the cameras"). The angle of
a two-vertex length out of the image plane (0°: side on; 90°: pointing at the camera) is therefore a fact
worth naming when it is large. Angles in degrees; points and camera in metres, one frame.
"""

from __future__ import annotations

import numpy as np

#: the largest angle (degrees) of a length out of the image plane the quality rules accept by default; a
#: project sets its own (``QualityRules.extra["max_out_of_plane_deg"]``)
MAX_OUT_OF_PLANE_DEG = 45.0


def out_of_plane_deg(points: np.ndarray, camera: np.ndarray | None) -> float | None:
    """The angle (degrees, 0..90) between a two-vertex object's segment and the image plane at its middle
    (the plane perpendicular to the line of sight from ``camera``, the left perspective centre); None when
    it is not a two-vertex object, the camera is unknown or the segment has no length."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if camera is None or len(points) != 2:
        return None
    segment = points[1] - points[0]
    sight = points.mean(axis=0) - np.asarray(camera, dtype=np.float64)
    norms = np.linalg.norm(segment) * np.linalg.norm(sight)
    if not norms > 0:
        return None
    return float(np.degrees(np.arcsin(min(1.0, abs(float(segment @ sight)) / norms))))
