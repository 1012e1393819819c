"""A detection model's proposals on the images shown, for review (Qt-free): a circle of 95 % around each
keypoint from its measured σ (:func:`sigma_circles`), the keypoints a reviewer may drag
(:func:`proposal_keypoints`), and a dragged keypoint's correction as one undoable edit
(:func:`correct_keypoint`). Light on purpose — no detection, no model — so that the window draws the
proposals stored by ``usvips detect`` or an earlier session without importing the detector
(:mod:`usvips.gui.detect_model` runs *Detect*)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from usvips.app.proposals import is_proposal
from usvips.core.errors import UsvipsError
from usvips.core.measurements import measure_picks
from usvips.core.pointing import HAND_CLICK_SIGMA_PX, Source
from usvips.gui.workspace import Workspace
from usvips.store.annotator import current_annotator
from usvips.store.records import StoredObject, Vertex

#: a circle of radius k·σ holds a keypoint's true point with 95 % probability (σ per coordinate, 2-D
#: normal: k² is the chi-square quantile of 2 degrees of freedom, −2 ln 0.05)
CIRCLE_SIGMAS = float(np.sqrt(-2.0 * np.log(0.05)))


def sigma_circles(workspace: Workspace) -> dict[str, np.ndarray]:
    """Per side, (n, 3) circles (x, y px; radius px) around the keypoints of the model proposals on the
    pair or frame shown whose vertices are all still the model's keypoints: radius :data:`CIRCLE_SIGMAS` ×
    the keypoint's measured pointing σ (95 %); none for a proposal without a measured σ."""
    out = {"left": [], "right": []}
    place = workspace.place()
    for stored in workspace.cache.objects():
        if not is_proposal(stored) or workspace.place_of(stored.id) != place:
            continue
        for v in stored.vertices:
            if v.pointing_px is None:
                continue
            out["left"].append((v.xl, v.yl, CIRCLE_SIGMAS * v.pointing_px[0]))
            out["right"].append((v.xr, v.yr, CIRCLE_SIGMAS * v.pointing_px[1]))
    return {side: np.array(rows, float).reshape(-1, 3) for side, rows in out.items()}


def proposal_keypoints(workspace: Workspace) -> list[tuple[int, int, str, tuple[float, float]]]:
    """(object id, vertex index, side, pixel) of every keypoint of the proposals on the pair or frame shown
    whose vertices are all still the model's keypoints — the points a reviewer may drag to correct."""
    out = []
    place = workspace.place()
    for stored in workspace.cache.objects():
        if is_proposal(stored) and workspace.place_of(stored.id) == place:
            for index, v in enumerate(stored.vertices):
                out += [(stored.id, index, "left", (v.xl, v.yl)), (stored.id, index, "right", (v.xr, v.yr))]
    return out


def corrected_vertices(stored: StoredObject, index: int, side: str, pixel: tuple[float, float], geometry,
                       annotator: str) -> list[Vertex]:
    """The vertices of a proposal with vertex ``index``'s ``side`` ("left" or "right") point moved to
    ``pixel`` by a reviewer: that vertex's source becomes the reviewer's hand click (its pointing σ on the
    moved side the hand-click default, the other side's kept) and the object is measured again with its
    calibration (``geometry``: the pair's, None leaves the 3-D points out)."""
    if side not in ("left", "right"):
        raise UsvipsError(f"a keypoint is moved in the left or right image, not {side!r}")
    vertices = list(stored.vertices)
    if not 0 <= index < len(vertices):
        raise UsvipsError(f"object {stored.id} has vertices 1 to {len(vertices)}, not {index + 1}")
    old = vertices[index]
    x, y = float(pixel[0]), float(pixel[1])
    point = old.source.split("(", 1)[1].split(",", 1)[0].strip() if "(" in old.source else ""
    label = Source("hand click", point if point in ("snout", "fork") else "", annotator).label
    sigma = old.pointing_px if old.pointing_px is not None else None
    if sigma is not None:
        sigma = (HAND_CLICK_SIGMA_PX, sigma[1]) if side == "left" else (sigma[0], HAND_CLICK_SIGMA_PX)
    moved = replace(old, **({"xl": x, "yl": y} if side == "left" else {"xr": x, "yr": y}), source=label,
                    pointing_px=sigma)
    vertices[index] = moved
    if geometry is None or any(v.pointing_px is None for v in vertices):
        return [replace(v, xyz=None, covariance=None, calibration_id=None) for v in vertices]
    left = np.array([(v.xl, v.yl) for v in vertices])
    right = np.array([(v.xr, v.yr) for v in vertices])
    sigmas = np.array([v.pointing_px for v in vertices], float)
    m = measure_picks(stored.kind, geometry.calibration, left, right, geometry.station, geometry.frame,
                      pointing_sigma_px=sigmas)
    return [replace(v, xyz=tuple(map(float, m.points[i])), covariance=m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3],
                    calibration_id=geometry.calibration_id) for i, v in enumerate(vertices)]


def correct_keypoint(workspace: Workspace, object_id: int, index: int, side: str, pixel: tuple[float, float]) -> None:
    """Move a proposal's keypoint (vertex ``index``, in the ``side`` image) to ``pixel`` as one undoable
    edit (the object returns to unreviewed until accepted again)."""
    stored = workspace.stored_object(object_id)
    vertices = corrected_vertices(stored, index, side, pixel, workspace.geometry, current_annotator())
    project = workspace.project
    name = "snout" if index == 0 else "fork" if index == len(vertices) - 1 else f"vertex {index + 1}"
    workspace.edit_stored(f"correct the {side} {name} of object {object_id}", object_id,
                          lambda version: project.update_object(object_id, vertices=vertices,
                                                                expected_modified=version))
