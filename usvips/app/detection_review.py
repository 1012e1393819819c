"""What reviewers' corrections say of a model's keypoints: each accepted proposal of the model, its
keypoints as the model proposed them (the object's first row of history, when it was added) against where
the reviewer left them (the object as it stands: re-picked, or accepted as proposed), measured into each
keypoint's pointing sigma by :func:`usvips.core.detection.keypoint_sigma.sigma_from_corrections`.

Only the LEFT image's keypoints are used: they are the model's own points, whereas a right keypoint may
have been refined along the epipolar curve (it then follows the left one, usvips/core/detection/refine.py).
A proposal is the model's when its vertices' source names the model's tag (name and hash): a retrained
model is a new model, measured anew."""

from __future__ import annotations

import numpy as np

from usvips.app.detection_model import DetectionModel
from usvips.app.detection_service import KEYPOINTS, source_label
from usvips.core.detection.keypoint_sigma import KeypointSigma, sigma_from_corrections
from usvips.core.pointing import HAND_CLICK_SIGMA_PX
from usvips.store.interface import ProjectStore


def review_corrections(project: ProjectStore, model: DetectionModel) -> tuple[np.ndarray, np.ndarray]:
    """(proposed, reviewed) left keypoints (n, 2, 2) px — snout and fork — of the accepted proposals of
    ``model`` in ``project`` (their right keypoints refined along the left's curve or not, stored with a
    length or without)."""
    # every source the service stores a keypoint of the model under: its right point refined or not, measured
    # or not (a measured proposal of a model with a frame correlation says so in its source)
    labels = [{source_label(point, model, follows, measured) for follows in (False, True) for measured in (False, True)}
              for point in KEYPOINTS]
    accepted = {r.object_id for r in project.reviews("accepted")}
    proposed, reviewed = [], []
    for stored in project.objects_with_ids(sorted(accepted)):
        added = next((h for h in project.history(stored.id) if h.change == "add"), None)
        if added is None or not added.new or len(stored.vertices) != len(KEYPOINTS):
            continue
        first = added.new.get("vertices", [])
        if not all(v.get("source") in label for v, label in zip(first, labels, strict=False)) \
                or len(first) != len(labels):
            continue
        proposed.append([(float(v["xl"]), float(v["yl"])) for v in first])
        reviewed.append([(v.xl, v.yl) for v in stored.vertices])
    return np.array(proposed, float).reshape(-1, 2, 2), np.array(reviewed, float).reshape(-1, 2, 2)


def sigma_from_reviews(project: ProjectStore, model: DetectionModel,
                       reviewer_sigma_px: float = HAND_CLICK_SIGMA_PX, date: str = "") -> dict[str, KeypointSigma]:
    """Each keypoint's pointing sigma (px) of ``model`` from the reviewers' corrections of its accepted
    proposals in ``project`` (refused by name with too few)."""
    proposed, reviewed = review_corrections(project, model)
    return sigma_from_corrections(KEYPOINTS, proposed, reviewed, reviewer_sigma_px, date)


def description_table(measured: dict[str, KeypointSigma], basis: str) -> str:
    """The ``[keypoint_sigma]`` table of a description file holding ``measured`` (docs/detection.md)."""
    values = ", ".join(f'"{name}" = {s.sigma.value_px:.3f}' for name, s in measured.items())
    return f'[keypoint_sigma]\nbasis = "{basis}"\npx = {{{values}}}\n'
