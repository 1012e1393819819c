"""A reviewer's correction of a model's proposal (Qt-free, no detector): one keypoint moved in one image
to where the reviewer put it, and the object measured again (:func:`corrected_vertices`; the window's drag,
:func:`usvips.gui.proposal_marks.correct_keypoint`, stores it as one undoable edit).

The moved point is the reviewer's hand click (its pointing σ the project's hand-click estimate in use for the
reviewer, :func:`hand_click_sigma`, as their other clicks take; without one the hand-click default,
:data:`usvips.core.pointing.HAND_CLICK_SIGMA_PX`); every other point keeps the model's σ stored with the
proposal — for a proposal stored without a length too, which keeps the σ it would have been measured with
(:func:`usvips.app.detection_service.proposal_vertices`). The moved vertex's source becomes the hand click,
so its left and right errors are independent from then on: a right point refined along the old left one's
curve carried the OLD left point's error, which the click does not share, and a clicked right point follows
nothing. The other vertices keep their sources, and with them the left–right correlation of a refined right
point (:func:`usvips.core.pointing.vertex_correlation`), so the 3-D points stored here are the ones the
object's figure, recomputed from its picks (:mod:`usvips.app.project_figures`), gives.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from usvips.app.pointing_settings import pointing_in_use, resolve
from usvips.core.errors import DegenerateGeometryError, UsvipsError
from usvips.core.measurements import measure_picks
from usvips.core.pointing import HAND_CLICK_SIGMA_PX, Source, vertex_correlation
from usvips.core.validation import positive
from usvips.store.interface import ProjectStore
from usvips.store.records import StoredObject, Vertex


def hand_click_sigma(project: ProjectStore, annotator: str) -> float:
    """The pointing σ (px, one image coordinate) a click of ``annotator`` takes in ``project``: the hand-click
    estimate in use for them, else anyone's (:mod:`usvips.app.pointing_settings`), else the hand-click
    default. A moved keypoint stores it: the vertex keeps the model's σ on its other side, so the figure path
    cannot apply the estimate to the moved side later."""
    found = resolve(pointing_in_use(project), "hand click", annotator)
    return HAND_CLICK_SIGMA_PX if found is None else float(found.value_px)


def corrected_vertices(stored: StoredObject, index: int, side: str, pixel: tuple[float, float], geometry,
                       annotator: str, click_sigma_px: float = HAND_CLICK_SIGMA_PX) -> list[Vertex]:
    """The vertices of a proposal with vertex ``index``'s ``side`` ("left" or "right") point moved to
    ``pixel`` (image px) by a reviewer ``annotator``: that vertex's source becomes the reviewer's hand click
    (its pointing σ on the moved side ``click_sigma_px``, the reviewer's :func:`hand_click_sigma`; the other
    side's kept) and the object is
    measured again with its pair's calibration (``geometry``: a :class:`usvips.app.pair_geometry.PairGeometry`;
    None, or a vertex without a pointing σ, leaves the 3-D points out; so do picks whose rays do not meet in
    front of the cameras — another keypoint still wrong, as when the first of a refused pair's keypoints is
    moved: the object is measured once the rest are corrected)."""
    if side not in ("left", "right"):
        raise UsvipsError(f"a keypoint is moved in the left or right image, not {side!r}")
    vertices = list(stored.vertices)
    if not 0 <= index < len(vertices):
        raise UsvipsError(f"object {stored.id} has vertices 1 to {len(vertices)}, not {index + 1}")
    old = vertices[index]
    x, y = float(pixel[0]), float(pixel[1])
    point = old.source.split("(", 1)[1].split(",", 1)[0].strip() if "(" in old.source else ""
    label = Source("hand click", point if point in ("snout", "fork") else "", annotator).label
    click = positive("click_sigma_px", click_sigma_px)
    sigma = old.pointing_px
    if sigma is not None:
        sigma = (click, sigma[1]) if side == "left" else (sigma[0], click)
    moved = replace(old, **({"xl": x, "yl": y} if side == "left" else {"xr": x, "yr": y}), source=label,
                    pointing_px=sigma)
    vertices[index] = moved
    if geometry is None or any(v.pointing_px is None for v in vertices):
        return [replace(v, xyz=None, covariance=None, calibration_id=None) for v in vertices]
    left = np.array([(v.xl, v.yl) for v in vertices])
    right = np.array([(v.xr, v.yr) for v in vertices])
    sigmas = np.array([v.pointing_px for v in vertices], float)
    try:
        m = measure_picks(stored.kind, geometry.calibration, left, right, geometry.station, geometry.frame,
                          pointing_sigma_px=sigmas,
                          pointing_correlation=vertex_correlation([v.source for v in vertices], sigmas))
    except DegenerateGeometryError:  # another keypoint still wrong: its rays do not meet until it is corrected
        return [replace(v, xyz=None, covariance=None, calibration_id=None) for v in vertices]
    return [replace(v, xyz=tuple(map(float, m.points[i])), covariance=m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3],
                    calibration_id=geometry.calibration_id) for i, v in enumerate(vertices)]
