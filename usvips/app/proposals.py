"""Which stored objects a detection model proposed: their vertices' sources name a model's keypoint
(``keypoint (<point>, model <name> sha256:<12 hex>…)``, :func:`usvips.app.detection_service.source_label`).
Its own small module so that the window can find proposals on the images without importing detection."""

from __future__ import annotations

from usvips.store.records import StoredObject


def is_proposal(stored: StoredObject) -> bool:
    """Whether a stored object was proposed by a model (its vertices' source is a model keypoint)."""
    return bool(stored.vertices) and all(v.source.startswith("keypoint (") and "model " in v.source
                                         for v in stored.vertices)
