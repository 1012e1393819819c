"""The calibration session's events, without a window: step, data (with the keys changed) and result."""

from usvips.app.samples import open_or_create_from_manifest
from usvips.gui.calibration_session import CalibrationSession


def test_the_session_announces_step_data_and_result(sample_copy):
    project = open_or_create_from_manifest(sample_copy("rov_flatport"))
    try:
        session = CalibrationSession(project, "water")
        events = []
        session.step_changed.connect(lambda step: events.append(("step", step)))
        session.data_changed.connect(lambda what, keys: events.append(("data", what, keys)))
        session.result_changed.connect(lambda: events.append(("result",)))
        session.set_step("pairs")
        session.set_step("pairs")  # the same step: no event
        session.set_pairs(["water1"])
        assert session.load_project_observations() > 0
        point = session.measured("water1")[0]
        session.set_observation("water1", point, (100.0, 120.0), (90.0, 121.0))
        session.remove_observation("water1", point)
        assert events == [("step", "pairs"), ("data", "pairs", ()), ("data", "observations", ()),
                          ("data", "observations", (("water1", point),)),
                          ("data", "observations", (("water1", point),))]
        events.clear()
        result = session.job()()
        session.set_result(result)
        assert events == [("result",)]
        events.clear()
        session.set_observation("water1", point, (100.0, 120.0), (90.0, 121.0))  # the result is of other data
        assert events == [("data", "observations", (("water1", point),)), ("result",)] and session.result is None
    finally:
        project.close()


def test_a_check_point_is_data_and_drops_the_result(sample_copy):
    project = open_or_create_from_manifest(sample_copy("rov_flatport"))
    try:
        session = CalibrationSession(project, "water")
        session.set_pairs(["water1"])
        session.load_project_observations()
        point = session.measured("water1")[0]
        session.set_result(session.job()())
        events = []
        session.data_changed.connect(lambda what, keys: events.append(("data", what, keys)))
        session.result_changed.connect(lambda: events.append(("result",)))
        session.set_check("water1", point, True)
        session.set_check("water1", point, True)  # no change: no event
        assert ("water1", point) in session.check and session.result is None
        session.set_check("water1", point, False)
        assert ("water1", point) not in session.check
        assert events == [("data", "check", (("water1", point),)), ("result",), ("data", "check", (("water1", point),))]
    finally:
        project.close()
