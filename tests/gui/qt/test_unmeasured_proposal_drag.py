"""In a window: a proposal stored by ``usvips detect`` WITHOUT a length (its pair refused) but with the sigma
it would have been measured with (usvips.app.detection_service.STORE_UNMEASURED_SIGMA) gets its 95 % circles,
and dragging its wrong keypoint's handle to the right place measures it — its length appears."""

import numpy as np
import pytest
from PySide6 import QtCore

from tests.app.detection_scenes import make_project
from tests.app.test_unmeasured_proposals import refused_scene, stereo_model
from tests.gui.conftest import open_sample, review_circles
from usvips.app.detection_service import detect_in_project
from usvips.app.project_figures import measure_stored
from usvips.store import Project


def test_dragging_the_wrong_keypoint_of_a_proposal_without_a_length_measures_it(qtbot, make_window, tmp_path,
                                                                                monkeypatch):
    """With STORE_UNMEASURED_SIGMA on (off in the shipped code: docs/detection.md, "A corrected proposal's σ")."""
    import usvips.app.detection_service as service

    monkeypatch.setattr(service, "STORE_UNMEASURED_SIGMA", True)

    truth, true_fork = refused_scene()
    path = make_project(tmp_path)
    with Project.open(path) as project:
        run = detect_in_project(project, stereo_model(truth), pair="dive", refine=False)
    lacking = next(p for p in run.proposals if p.measurement is None)
    window = make_window()
    open_sample(qtbot, window, path, "dive")
    circles = review_circles(qtbot, window)
    # every proposal's keypoints get their circles, the one without a length's too (3 fish × snout, fork)
    assert {side: len(item.points()) for side, item in circles.items.items()} == {"left": 6, "right": 6}
    qtbot.waitUntil(lambda: len(circles.handles) == 12, timeout=5000)
    project = window.workspace.project
    assert project.object(lacking.object_id).vertices[1].xyz is None
    handle, _ = circles.handles[(lacking.object_id, 1, "right")]
    handle.setPos(QtCore.QPointF(*(np.asarray(true_fork) + 0.5)))  # view coordinates: pixel + half a pixel
    handle.dropped.emit(handle)
    qtbot.waitUntil(lambda: project.object(lacking.object_id).vertices[1].xyz is not None, timeout=5000)
    figure = measure_stored(project, project.object(lacking.object_id)).main
    assert figure.value == pytest.approx(truth.lengths[0], abs=1e-6) and 0 < figure.sigma < 0.1 * figure.value
