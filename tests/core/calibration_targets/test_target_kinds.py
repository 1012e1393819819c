"""Target kinds: descriptions round-trip and refuse contradictions by field; the printed patterns are
OpenCV's; the printable shapes are the pattern."""

import cv2
import numpy as np
import pytest

from usvips.core.calibration_targets import from_description, kind, names
from usvips.core.errors import InputFileError, InvalidParameterError

GOOD = {
    "chessboard": {"kind": "chessboard", "cols": 9, "rows": 6, "square": 0.024},
    "charuco": {"kind": "charuco", "dictionary": "5X5_100", "cols": 8, "rows": 6, "square": 0.03, "marker": 0.022},
    "marker-grid": {"kind": "marker-grid", "dictionary": "APRILTAG_36h11", "cols": 5, "rows": 4, "marker": 0.04,
                    "separation": 0.01},
    "circle-grid": {"kind": "circle-grid", "cols": 4, "rows": 11, "spacing": 0.02, "diameter": 0.015,
                    "asymmetric": True},
    "target-field": {"kind": "target-field", "mark": "cross", "size": 0.03,
                     "points": [[str(k), float(x), float(y), float(z)] for k, (x, y, z) in
                                enumerate(np.random.default_rng(0).uniform(-0.5, 0.5, (12, 3)))]},
}


def test_every_kind_is_registered_in_menu_order():
    assert names() == ("chessboard", "charuco", "marker-grid", "circle-grid", "target-field")


@pytest.mark.parametrize("name", list(GOOD))
def test_a_description_round_trips(name):
    target = from_description(GOOD[name])
    again = from_description(target.describe())
    assert again.describe() == target.describe()
    assert again.control_points().ids == target.control_points().ids
    np.testing.assert_array_equal(again.control_points().xyz, target.control_points().xyz)


def test_the_bases_are_abstract_and_every_kind_instantiates():
    """A kind that leaves out a method of its base cannot be made (abc), and every registered kind does."""
    import inspect

    from usvips.core.calibration_targets import CalibrationTarget
    from usvips.core.calibration_targets.kinds._board import PrintedBoard

    assert inspect.isabstract(CalibrationTarget) and inspect.isabstract(PrintedBoard)
    assert {"describe", "from_description", "control_points", "detect"} <= CalibrationTarget.__abstractmethods__
    assert {"ink", "sheet", "shapes", "feature_size", "points"} <= PrintedBoard.__abstractmethods__

    class Incomplete(PrintedBoard):
        def points(self):
            return (), np.zeros((0, 2))

    with pytest.raises(TypeError, match="abstract"):
        Incomplete()
    for name, description in GOOD.items():
        target = from_description(description)
        assert not inspect.isabstract(type(target)) and type(target) is kind(name)


def test_point_counts_and_planarity():
    counts = {"chessboard": 54, "charuco": 35, "marker-grid": 80, "circle-grid": 44, "target-field": 12}
    for name, description in GOOD.items():
        target = from_description(description)
        assert len(target.control_points()) == counts[name]
        assert target.is_planar == (name != "target-field")
        assert target.exact == (name != "target-field")


def test_chessboard_points_follow_opencvs_convention():
    points = from_description(GOOD["chessboard"]).control_points()
    assert points.ids[:3] == ("0", "1", "2")
    np.testing.assert_allclose(points.xyz[1], [0.024, 0, 0])
    np.testing.assert_allclose(points.xyz[9], [0, 0.024, 0])


BAD = [
    ("chessboard", {"square": 0}, "square", "> 0"),
    ("chessboard", {"square": -0.02}, "square", "> 0"),
    ("chessboard", {"square": 24}, "square", "millimetres"),
    ("chessboard", {"cols": 1}, "cols", "at least 2"),
    ("chessboard", {"rows": 5.5}, "rows", "whole number"),
    ("chessboard", {"cols": 8}, "upright", "half a turn"),
    ("chessboard", {"upright": "yes"}, "upright", "true or false"),
    ("chessboard", {"colour": 3}, "colour", "not a field"),
    ("charuco", {"marker": 0.03}, "marker", "smaller than the square"),
    ("charuco", {"dictionary": "4X4_50", "cols": 12, "rows": 10}, "dictionary", "has 50 markers"),
    ("charuco", {"dictionary": "5X5_77"}, "dictionary", "unknown dictionary"),
    ("charuco", {"rows": 2}, "rows", "at least 3"),
    ("marker-grid", {"dictionary": "APRILTAG_16h5", "cols": 6, "rows": 6}, "dictionary", "has 30 markers"),
    ("marker-grid", {"separation": 0}, "separation", "> 0"),
    ("circle-grid", {"diameter": 0.03}, "diameter", "touch"),
    ("circle-grid", {"rows": 10}, "upright", "half a turn"),
    ("circle-grid", {"cols": 1}, "cols", "at least 2"),  # one asymmetric column: printed, never found
    ("circle-grid", {"asymmetric": False, "cols": 5, "rows": 4, "diameter": 0.01}, "upright", "half a turn"),
    ("target-field", {"points": [["1", 0, 0, 0]] * 8}, "points", "given twice"),
    ("target-field", {"points": [["1", 0, 0, 0], ["2", 1, 0, 0]]}, "points", "at least 6"),
    ("target-field", {"mark": "star"}, "mark", "one of"),
    ("target-field", {"size": -1}, "size", "> 0"),
    ("target-field", {"points": [[str(k), k, 0, 0] for k in range(8)]}, "points", "one line"),
    ("target-field", {"points": [[str(k), k, "a", 0] for k in range(8)]}, "points", "row 1"),
]


@pytest.mark.parametrize(("name", "change", "field", "words"), BAD)
def test_a_contradictory_description_is_refused_naming_the_field(name, change, field, words):
    description = {**GOOD[name], **change}
    with pytest.raises(InvalidParameterError) as caught:
        from_description(description)
    assert caught.value.parameter == field and words in str(caught.value)
    with pytest.raises(InputFileError) as in_file:
        from_description(description, source="board.json")
    message = str(in_file.value)
    assert message.startswith("board.json: ") and repr(field) in message and words in message
    assert "\n" not in message
    assert in_file.value.parameter == field  # the front ends can name their own field for it


def test_missing_fields_and_unknown_kinds_are_named():
    with pytest.raises(InvalidParameterError, match="square: missing"):
        from_description({"kind": "chessboard", "cols": 9, "rows": 6})
    with pytest.raises(InvalidParameterError, match="unknown target kind 'checkerboard'.*chessboard"):
        from_description({"kind": "checkerboard"})
    with pytest.raises(InvalidParameterError, match="needs a \"kind\""):
        from_description({"cols": 9})


def _sample(board, width_px, height_px, metres_per_px, origin=(0.0, 0.0)):
    yy, xx = np.mgrid[0:height_px, 0:width_px]
    xy = np.column_stack([(xx.ravel() + 0.5) * metres_per_px + origin[0], (yy.ravel() + 0.5) * metres_per_px
                          + origin[1]])
    return board.ink(xy).reshape(height_px, width_px)


@pytest.mark.parametrize(("cols", "rows", "legacy", "dictionary"),
                         [(7, 5, False, "5X5_100"), (6, 4, False, "4X4_50"), (6, 4, True, "4X4_50"),
                          (5, 6, True, "6X6_250")])
def test_charuco_pattern_is_opencvs(cols, rows, legacy, dictionary):
    modules = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, f"DICT_{dictionary}")).markerSize + 2
    marker_px = 20 * modules  # whole pixels per module and per margin around the marker
    square_px = marker_px + 2 * round(0.2 * marker_px)
    board = kind("charuco")(dictionary, cols, rows, square_px * 1e-3, marker_px * 1e-3, legacy)
    opencv = board.board.generateImage((cols * square_px, rows * square_px), marginSize=0, borderBits=1)
    ours = _sample(board, cols * square_px, rows * square_px, 1e-3)
    assert np.array_equal(ours > 0.5, opencv < 128)


def test_marker_grid_pattern_is_opencvs():
    board = kind("marker-grid")("APRILTAG_36h11", 4, 3, 0.08, 0.02, first_id=7)
    pitch = 100
    width, height = 4 * pitch - 20, 3 * pitch - 20
    opencv = board.board.generateImage((width, height), marginSize=0, borderBits=1)
    ours = _sample(board, width, height, 1e-3)
    assert np.array_equal(ours > 0.5, opencv < 128)


@pytest.mark.parametrize("name", ["chessboard", "charuco", "marker-grid", "circle-grid"])
def test_printable_shapes_are_the_pattern(name):
    board = from_description(GOOD[name])
    rng = np.random.default_rng(3)
    x0, y0, x1, y1 = board.sheet()
    xy = rng.uniform((x0, y0), (x1, y1), (20000, 2))
    rectangles, circles = board.shapes()
    inked = np.zeros(len(xy), bool)
    for a, b, c, d in rectangles:
        inked |= (xy[:, 0] >= a) & (xy[:, 0] < c) & (xy[:, 1] >= b) & (xy[:, 1] < d)
    for cx, cy, r in circles:
        inked |= (xy[:, 0] - cx) ** 2 + (xy[:, 1] - cy) ** 2 <= r * r
    assert np.array_equal(inked, board.ink(xy) == 1)
    assert np.isnan(board.ink(np.array([[x1 + 0.01, y0], [x0 - 1, y1 + 1]]))).all()


def test_a_target_field_asks_to_identify_targets():
    field = from_description(GOOD["target-field"])
    detection = field.detect(np.zeros((40, 60), np.uint8))
    assert not detection and "identify at least 6 targets" in detection.reason
    assert detection.image_size == (60, 40)


def test_images_of_unsupported_types_are_refused_by_name():
    board = from_description(GOOD["chessboard"])
    with pytest.raises(InvalidParameterError, match="uint8 or uint16"):
        board.detect(np.zeros((50, 50), np.float32))
    with pytest.raises(InvalidParameterError, match="shape"):
        board.detect(np.zeros((50,), np.uint8))


def test_dictionary_names_accept_opencvs_spelling():
    a = kind("charuco")("DICT_4X4_50", 5, 4, 0.03, 0.02)
    b = kind("charuco")("4x4_50", 5, 4, 0.03, 0.02)
    assert a.describe() == b.describe() and a.describe()["dictionary"] == "4X4_50"
    assert cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50).bytesList.shape == a.dictionary.bytesList.shape


@pytest.mark.parametrize("name", list(GOOD))
def test_a_target_pickles_as_its_description(name):
    import pickle

    target = from_description(GOOD[name])
    again = pickle.loads(pickle.dumps(target))
    assert type(again) is type(target) and again.describe() == target.describe()
    image = np.full((60, 80), 128, np.uint8)
    assert again.detect(image).reason == target.detect(image).reason
