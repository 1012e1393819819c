"""What the views page of the target wizard lists and shows for each view, without Qt: every view of the
source — the ones the target was found in (ticked or not) and the ones set aside with why — and, for the
one opened, its points, its residual vectors once a calibration is computed, and its figures in words.

Residuals are v = observed − computed (pixels, x right, y down), from the adjustment's report; a
held-out view has no residuals of its own in the fit (its reprojection is in the validation).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from usvips.gui.target_session import TargetSession

#: residual vectors are drawn this many times their length (a 0.5 px residual: 25 image pixels)
RESIDUAL_SCALE = 50.0


@dataclass(frozen=True)
class ViewEntry:
    """One row of the views list: ``label``, ``found`` (False: set aside), ``text`` (the row) and ``why``
    (the reason a view was set aside; empty for a found one)."""

    label: str
    found: bool
    text: str
    why: str = ""


def entries(session: TargetSession) -> list[ViewEntry]:
    """The views found (with their point count) then those set aside (with their reason)."""
    views = session.views
    if views is None:
        return []
    rows = [ViewEntry(v.label, True, f"{v.label}  ({len(v.common_ids())} points)") for v in views.views]
    rows += [ViewEntry(label, False, f"{label}  — set aside", why) for label, why in views.set_aside]
    return rows


def set_aside_images(session: TargetSession, label: str) -> tuple[str, str] | None:
    """The (left, right) image files of a pair set aside, when the views came from image pairs (a pair's
    label is its left image's name, or ``k:name``); None when not known."""
    if session.source != "images":
        return None
    for k, (left, right) in enumerate(session.pairs):
        if label in (Path(left).stem, f"{k + 1}:{Path(left).stem}"):
            return left, right
    return None


def residual_segments(session: TargetSession, label: str, side: str, scale: float = RESIDUAL_SCALE
                      ) -> np.ndarray:
    """(2·N, 2) pixel end points, pairwise, of the residual vectors of view ``label`` in camera ``side``
    (``left``/``right``) drawn ``scale`` times their length from the observed point; empty before a
    calibration or for a view not fitted."""
    result = session.result
    if result is None or session.views is None:
        return np.zeros((0, 2))
    detection = getattr(session.view(label), side)
    where = {pid: px for pid, px in zip(detection.ids, detection.pixels, strict=True)}
    letter = side[0]
    segments = []
    for row in result.result.report.used_residuals():
        if row.station != label or row.side != letter or row.vx is None or row.vy is None:
            continue
        start = where.get(row.id)
        if start is None:
            continue
        segments += [start, start + scale * np.array([row.vx, row.vy])]
    return np.array(segments, float).reshape(-1, 2)


def detail(session: TargetSession, label: str) -> str:
    """What a person reads about one view: its points per camera and in both, ticked or not, and after a
    calibration its RMS (fitted) or that it was held out; for a view set aside, why."""
    views = session.views
    if views is None:
        return ""
    for aside, why in views.set_aside:
        if aside == label:
            return f"set aside: {why}"
    view = session.view(label)
    used = "used" if session.ticked.get(label) else "unticked: not used"
    text = (f"{label}: {len(view.left.ids)} points found left, {len(view.right.ids)} right, "
            f"{len(view.common_ids())} in both; {used}")
    result = session.result
    if result is not None:
        rms = result.view_rms()
        if label in rms:
            text += f"; reprojection RMS {rms[label]:.3f} px (red: residuals ×{RESIDUAL_SCALE:g})"
        elif result.validation is not None and label in result.validation.held_out.views:
            held = result.validation.held_out.rms_px_by_view.get(label)
            text += "; held out for validation" + (f": reprojects at {held:.3f} px" if held is not None else "")
    return text
