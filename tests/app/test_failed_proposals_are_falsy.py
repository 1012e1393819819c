"""The app's estimator outputs that can fail are falsy when they did, with the reason kept (the pattern of
detections and calibrations)."""

from __future__ import annotations

from usvips.app.tracking import VertexProposal
from usvips.app.view_detection import DetectedViews


def test_a_vertex_without_a_proposal_is_falsy_and_says_why():
    proposed = VertexProposal((1.0, 2.0), (3.0, 4.0))
    stopped = VertexProposal(None, None, "the track lost the target at frame 40")
    assert proposed and not stopped and stopped.reason


def test_a_frame_set_without_a_usable_view_is_falsy_and_names_every_instant():
    nothing = DetectedViews((), (), (("f1", "too blurred"), ("f2", "target not found")), 2, 1, 0, 0, 1, 0)
    assert not nothing and nothing.reasons() == {"f1": "too blurred", "f2": "target not found"}
