"""Stored figures use each vertex's own pointing sigma: a stated sigma is the one the figure uses (and
says), a vertex of unknown source (stored before schema 11) uses the hand-click default and the figure says
so; tracked instants carry the sigma of the pick they were tracked from."""

import numpy as np
import pytest

from usvips.app.project_figures import evaluate, measurement_input
from usvips.bench import scaling
from usvips.core.measurements.breakdown import breakdown_cells, breakdown_text
from usvips.core.pointing import HAND_CLICK_SIGMA_PX, MIGRATED_SOURCE, vertex_pointing
from usvips.io.calibration_file import calibration_to_dict, load_calibration
from usvips.store import Project
from usvips.store.project import Vertex


def _fish(path, **pointing):
    calibration = load_calibration(scaling.CALIBRATION)
    rig = calibration.rig(0, "rig")
    ends = np.array([[0.05, 0.0, -2.4], [0.35, 0.02, -2.45]])
    picks = np.hstack([rig.left.project(ends).pixels, rig.right.project(ends).pixels])
    with Project.create(path) as project:
        project.add_pair("dive")
        calibration_id = project.add_calibration("cal", calibration_to_dict(calibration), ("dive",))
        return project.add_object("length", [Vertex(*map(float, p), calibration_id=calibration_id, pair="dive",
                                                    **pointing) for p in picks])


def _measured(path, object_id):
    with Project.open(path, read_only=True) as project:
        return evaluate(measurement_input(project, project.object(object_id)))


def test_a_stated_pointing_sigma_is_the_figures_and_its_share_scales_with_it(tmp_path):
    default = _measured(tmp_path / "a.usvips", _fish(tmp_path / "a.usvips"))
    stated = _measured(tmp_path / "b.usvips", _fish(tmp_path / "b.usvips", pointing_px=(1.0, 1.0),
                                                    pointing_origin="estimated"))
    assert default.pointing_origin == "default" and stated.pointing_origin == "estimated"
    np.testing.assert_allclose(default.pointing_sigma_px, HAND_CLICK_SIGMA_PX)
    # the pointing share grows with the pointing sigma: in proportion at first order, a little faster with its
    # second-order part (this 30 cm fish at 2.4 m has a depth σ of ~6 % of its length at 1 px); the
    # calibration's share does not depend on it
    growth = stated.main.sigma_pointing / (default.main.sigma_pointing / HAND_CLICK_SIGMA_PX)
    assert 1 - 2e-3 <= growth <= 1.15
    assert stated.main.sigma_calibration == pytest.approx(default.main.sigma_calibration, rel=2e-3)
    cells = breakdown_cells(stated)
    assert (cells["pointing_sigma_px"], cells["pointing_origin"], cells["sigma_notes"]) == ("1", "estimated", "")
    assert "(pointing σ 1 px, estimated)" in breakdown_text(stated)


def test_vertices_of_unknown_source_use_the_default_and_the_figure_says_so(tmp_path):
    path = tmp_path / "old.usvips"
    object_id = _fish(path, source=MIGRATED_SOURCE)  # what the migration to schema 11 gives older vertices
    m = _measured(path, object_id)
    np.testing.assert_allclose(m.pointing_sigma_px, HAND_CLICK_SIGMA_PX)
    assert any("unknown source" in mark for mark in m.marks) and "unknown source" in breakdown_text(m)
    sigma, origin, marks = vertex_pointing(["hand click", "auto-match"], [(0.3, 0.4), None], ["given", "default"])
    np.testing.assert_allclose(sigma, [[0.3, 0.4], [0.5, 0.5]])
    assert origin == "default+given" and marks == ()
