"""A detection model's proposals on the images shown, for review (Qt-free): a circle of 95 % around each
keypoint from its measured σ (:func:`sigma_circles`), the keypoints a reviewer may drag
(:func:`proposal_keypoints`), and a dragged keypoint's correction as one undoable edit
(:func:`correct_keypoint`, measured again by :func:`usvips.app.proposal_correction.corrected_vertices`).
Light on purpose — no detection, no model — so that the window draws the proposals stored by
``usvips detect`` or an earlier session without importing the detector (:mod:`usvips.gui.detect_model` runs
*Detect*)."""

from __future__ import annotations

import numpy as np

from usvips.app.proposal_correction import corrected_vertices, hand_click_sigma
from usvips.app.proposals import is_proposal
from usvips.gui.workspace import Workspace
from usvips.store.annotator import current_annotator

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


def correct_keypoint(workspace: Workspace, object_id: int, index: int, side: str, pixel: tuple[float, float]) -> None:
    """Move a proposal's keypoint (vertex ``index``, in the ``side`` image) to ``pixel`` as one undoable
    edit (the object returns to unreviewed until accepted again)."""
    stored = workspace.stored_object(object_id)
    project, annotator = workspace.project, current_annotator()
    vertices = corrected_vertices(stored, index, side, pixel, workspace.geometry, annotator,
                                  hand_click_sigma(project, annotator))
    name = "snout" if index == 0 else "fork" if index == len(vertices) - 1 else f"vertex {index + 1}"
    workspace.edit_stored(f"correct the {side} {name} of object {object_id}", object_id,
                          lambda version: project.update_object(object_id, vertices=vertices,
                                                                expected_modified=version))
