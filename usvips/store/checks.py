"""The domain checks every backend makes before it writes: measurement kinds and their vertex counts,
vertex picks, image-pair files and labels. One place, above the implementations, so that a new backend
refuses exactly what SQLite refuses, with the same one-line messages.

``where`` is how the project is named in messages (a file path, or a server address without password).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from pathlib import Path

import numpy as np

from usvips.core.errors import UsvipsError
from usvips.core.measurements import kind as measurement_kind
from usvips.core.measurements import resolve as resolve_kind
from usvips.store.records import REVIEW_STATES, ProjectError, Vertex


def object_kind(kind: str, vertices: Sequence[Vertex], where: object) -> str:
    """The registered kind an object of ``kind`` with these vertices is stored as (the legacy ``line``
    becomes ``length`` or ``arc`` by its vertex count). Every vertex needs both picks (finite pixels);
    the vertex count must suit the kind."""
    for i, vertex in enumerate(vertices):
        values = (vertex.xl, vertex.yl, vertex.xr, vertex.yr)
        if any(v is None or not np.isfinite(v) for v in values):
            raise ProjectError(f"vertex {i}: a vertex needs both picks (left and right pixel)")
    try:
        return kind_for_count(kind, len(vertices))
    except UsvipsError as error:
        raise ProjectError(f"{where}: cannot store the object: {error}") from None


def kind_for_count(kind: str, count: int) -> str:
    """The registered kind ``kind`` resolves to for ``count`` vertices; a ``UsvipsError`` naming the kind
    when it is unknown or the count does not suit it."""
    name = resolve_kind(kind, count)
    measurement_kind(name).check_count(count)
    return name


def pair_images(label: str, left: str | Path | None, right: str | Path | None) -> None:
    """The image files of a new pair exist (either may be None: a pair without images)."""
    for side, image in (("left", left), ("right", right)):
        if image is not None and not Path(image).is_file():
            raise ProjectError(f"pair {label!r}: the {side} image {image} does not exist")


def image_pairs(pairs: Sequence[tuple[str, Path, Path]], taken: Collection[str], where: object) -> None:
    """(label, left, right) pairs to add: a label already ``taken`` or given twice, or one file as both
    left and right, is one line naming the pair (nothing is added)."""
    labels = [label for label, _, _ in pairs]
    repeated = sorted({label for label in labels if label in taken or labels.count(label) > 1})
    if repeated:
        shown = ", ".join(repr(label) for label in repeated[:5]) + (" …" if len(repeated) > 5 else "")
        raise ProjectError(f"{where}: image pair label(s) {shown} already used; choose another label or "
                           "label prefix (nothing was added)")
    for label, left, right in pairs:
        if Path(left).resolve() == Path(right).resolve():
            raise ProjectError(f"{where}: pair {label!r}: {left} is both the left and the right image "
                               "(nothing was added)")


MAX_REASON_LENGTH = 500


def review(object_id: int, state: str, reason: str, where: object) -> tuple[str, str]:
    """(state, reason stripped) of a review to store: a state of :data:`~usvips.store.records.REVIEW_STATES`;
    a flag needs a reason; a reason is one line of at most :data:`MAX_REASON_LENGTH` characters and goes
    only with accepted or flagged. Anything else is one line naming the object and what is wrong."""
    if state not in REVIEW_STATES:
        raise ProjectError(f"{where}: object {object_id}: unknown review state {state!r} (one of "
                           f"{', '.join(REVIEW_STATES)})")
    text = str(reason or "").strip()
    if state == "flagged" and not text:
        raise ProjectError(f"{where}: object {object_id}: a flag needs a reason (say what is wrong, on one line)")
    if state == "unreviewed" and text:
        raise ProjectError(f"{where}: object {object_id}: an unreviewed object has no reason (give the reason "
                           "with a flag or an accept)")
    if len(text) > MAX_REASON_LENGTH:
        raise ProjectError(f"{where}: object {object_id}: the reason is {len(text)} characters long; at most "
                           f"{MAX_REASON_LENGTH} please")
    if any(ord(c) < 32 or ord(c) == 127 for c in text):
        raise ProjectError(f"{where}: object {object_id}: the reason holds a control character (a line break, a "
                           "tab, …); give it on one line")
    return state, text
