"""Detection: the same id is the same physical point whatever the board's orientation in the image; grey,
colour, 8 and 16 bits; refusals with a reason (absent, occluded, blurred, mirrored, symmetric)."""

import numpy as np
import pytest

from usvips.core.calibration_targets import kind
from usvips.core.camera import Camera, Exterior
from usvips.core.interior import Interior
from usvips.core.synth.boards import BoardPose, board_pixels, render_board

W, H = 480, 360


def _camera() -> Camera:
    return Camera(Interior(f=520.0, xp=239.5, yp=179.5, k1=-0.03), Exterior(0, 0, 0), width=W, height=H)


BOARDS = {
    "chessboard": lambda: kind("chessboard")(9, 6, 0.02),
    "charuco": lambda: kind("charuco")("5X5_100", 7, 5, 0.025, 0.018),
    "marker-grid": lambda: kind("marker-grid")("4X4_50", 4, 3, 0.04, 0.01),
    "circle-grid": lambda: kind("circle-grid")(4, 11, 0.012, 0.008, asymmetric=True),
}
TOLERANCE = {"chessboard": 0.3, "charuco": 0.3, "marker-grid": 0.45, "circle-grid": 0.3}


def _view(board, spin=0.3, tilt=0.3, distance=0.5, **render):
    camera = _camera()
    centre = board.control_points().xyz.mean(axis=0)[:2]
    pose = BoardPose.facing(camera, centre, (240, 180), distance, tilt=tilt, tilt_direction=0.5, spin=spin)
    ids, pixels, ok = board_pixels(camera, board, pose)
    assert ok.all()
    return render_board(camera, board, pose, supersample=3, **render), dict(zip(ids, pixels, strict=True))


def _turn(image, truth, quarter_turns):
    """The image turned by np.rot90 (anticlockwise on screen) and the truth pixels moved with it."""
    height, width = image.shape[:2]
    moved = {}
    for pid, (x, y) in truth.items():
        for _ in range(quarter_turns % 4):
            x, y = y, width - 1 - x
            width, height = height, width
        width, height = image.shape[1], image.shape[0]
        moved[pid] = np.array([x, y])
    return np.ascontiguousarray(np.rot90(image, quarter_turns)), moved


def _errors(detection, truth):
    return np.array([np.linalg.norm(detection.pixels[k] - truth[pid]) for k, pid in enumerate(detection.ids)])


@pytest.fixture(scope="module")
def views():
    return {name: _view(make()) for name, make in BOARDS.items()}


@pytest.mark.parametrize("name", list(BOARDS))
@pytest.mark.parametrize("quarter_turns", [0, 1, 2, 3])
def test_ids_name_the_same_physical_points_in_every_orientation(views, name, quarter_turns):
    board = BOARDS[name]()
    image, truth = _turn(*views[name], quarter_turns)
    detection = board.detect(image)
    assert detection, detection.reason
    assert len(detection) == len(truth)
    errors = _errors(detection, truth)
    assert errors.max() < TOLERANCE[name], (name, quarter_turns, errors.max())


@pytest.mark.parametrize("spin", np.linspace(-np.pi, np.pi, 9)[:-1])
def test_odd_by_even_chessboard_is_resolved_by_its_corner_square_at_every_spin(spin):
    board = BOARDS["chessboard"]()
    image, truth = _view(board, spin=float(spin), tilt=0.5)
    detection = board.detect(image)
    assert detection, detection.reason
    assert _errors(detection, truth).max() < 0.3


def test_a_mirrored_image_of_a_plain_board_reads_as_the_board_turned_over():
    """A chessboard's mirror image is a chessboard flipped top to bottom: the corner order it gets is the
    one the flipped board would give (never a mix; documented: cameras do not mirror)."""
    board = BOARDS["chessboard"]()
    image, truth = _view(board)
    mirrored = np.ascontiguousarray(image[:, ::-1])
    detection = board.detect(mirrored)
    assert detection
    for k, pid in enumerate(detection.ids):
        i, j = int(pid) % 9, int(pid) // 9
        x, y = truth[str((5 - j) * 9 + i)]
        assert np.linalg.norm(detection.pixels[k] - (W - 1 - x, y)) < 0.3


@pytest.mark.parametrize("name", ["charuco", "marker-grid"])
def test_a_mirrored_image_of_a_marker_board_is_refused(name):
    board = BOARDS[name]()
    image, _ = _view(board)
    detection = board.detect(np.ascontiguousarray(image[:, ::-1]))
    assert not detection and detection.reason


def test_symmetric_chessboard_with_the_upright_rule_keeps_its_order_up_to_a_quarter_turn():
    board = kind("chessboard")(8, 6, 0.02, upright=True)
    for spin in (-1.1, -0.4, 0.0, 0.7, 1.1):
        image, truth = _view(board, spin=spin)
        detection = board.detect(image)
        assert detection and "upright" in detection.notes[0]
        assert _errors(detection, truth).max() < 0.3


@pytest.mark.parametrize(("cols", "rows", "spin"), [(8, 6, np.pi / 2 - 0.05), (8, 6, -np.pi / 2 + 0.1),
                                                    (7, 7, np.pi / 4 + 0.05)])
def test_the_upright_rule_refuses_a_board_turned_where_two_orders_are_alike(cols, rows, spin):
    """Near a quarter turn (a square board: near an eighth) two cameras could pick different orders."""
    board = kind("chessboard")(cols, rows, 0.02, upright=True)
    image, _ = _view(board, spin=spin, tilt=0.1)
    detection = board.detect(image)
    assert not detection and "too near a quarter turn" in detection.reason


def test_a_square_board_with_the_upright_rule_keeps_its_order_when_nearly_upright():
    board = kind("chessboard")(7, 7, 0.02, upright=True)
    for spin in (-0.3, 0.0, 0.25, np.pi / 2 + 0.2, np.pi - 0.1):
        image, truth = _view(board, spin=spin, tilt=0.2)
        detection = board.detect(image)
        assert detection, (spin, detection.reason)
        quarter = int(np.rint(spin / (np.pi / 2))) % 4
        turned = np.rot90(np.array(board.points()[0]).reshape(7, 7), -quarter).ravel()
        # the upright rule names corner 0 the top-left one as seen: the board's ids turn with the board
        errors = [np.linalg.norm(detection.pixels[k] - truth[turned[k]]) for k in range(len(detection))]
        assert max(errors) < 0.3, spin


@pytest.mark.parametrize("name", list(BOARDS))
def test_grey_colour_and_sixteen_bits_agree(name):
    board = BOARDS[name]()
    camera = _camera()
    centre = board.control_points().xyz.mean(axis=0)[:2]
    pose = BoardPose.facing(camera, centre, (240, 180), 0.5, tilt=0.3, spin=0.2)
    ids, pixels, _ = board_pixels(camera, board, pose)
    truth = dict(zip(ids, pixels, strict=True))
    detections = [board.detect(render_board(camera, board, pose, supersample=2, **options))
                  for options in ({}, {"colour": True}, {"dtype": np.uint16})]
    assert all(detections)
    assert detections[0].ids == detections[1].ids == detections[2].ids
    for detection in detections:
        assert _errors(detection, truth).max() < TOLERANCE[name]


@pytest.mark.parametrize("name", list(BOARDS))
def test_an_image_without_the_board_is_refused_with_a_reason(name):
    rng = np.random.default_rng(1)
    clutter = np.clip(100 + 30 * rng.standard_normal((H, W)), 0, 255).astype(np.uint8)
    detection = BOARDS[name]().detect(clutter)
    assert not detection and detection.reason and len(detection) == 0


def test_an_occluded_chessboard_is_refused_but_a_charuco_board_gives_what_is_seen(views):
    chess, truth = views["chessboard"]
    covered = chess.copy()
    covered[:, :200] = 100
    detection = BOARDS["chessboard"]().detect(covered)
    assert not detection and "every inner corner must be in view" in detection.reason

    image, truth = views["charuco"]
    covered = image.copy()
    covered[:, :220] = 100
    detection = BOARDS["charuco"]().detect(covered)
    assert detection and 0 < len(detection) < len(truth)
    assert _errors(detection, truth).max() < 0.3
    assert all(truth[pid][0] > 215 for pid in detection.ids)


@pytest.mark.parametrize("name", ["chessboard", "charuco"])
def test_a_board_moving_too_fast_is_refused_as_blurred(name):
    board = BOARDS[name]()
    for length, angle in ((7.0, 0.4), (14.0, 2.0)):
        image, _ = _view(board, motion=length, motion_angle=angle)
        detection = board.detect(image)
        assert not detection
        assert "blurred" in detection.reason or "found" in detection.reason
    image, _ = _view(board, motion=7.0, motion_angle=0.4)
    assert board.detect(image).reason.startswith("the target is too blurred") or name == "charuco"


def test_quality_falls_with_blur():
    board = BOARDS["charuco"]()
    sharp = board.detect(_view(board)[0])
    soft = board.detect(_view(board, blur=1.0)[0])
    assert sharp and soft
    common = [pid for pid in sharp.ids if pid in soft.ids]
    assert np.median(sharp.subset(common).quality) > 1.1 * np.median(soft.subset(common).quality)


ODD_IMAGES = {
    "8 x 8": np.zeros((8, 8), np.uint8),
    "a thin strip": np.zeros((8, 3000), np.uint8),
    "16-bit noise": np.random.default_rng(0).integers(0, 65535, (200, 300)).astype(np.uint16),
    "16-bit black": np.zeros((100, 100), np.uint16),
    "RGBA": np.zeros((50, 60, 4), np.uint8),
}


@pytest.mark.parametrize("name", list(BOARDS))
@pytest.mark.parametrize("image", list(ODD_IMAGES))
def test_odd_images_give_a_reason_never_an_exception(name, image):
    detection = BOARDS[name]().detect(ODD_IMAGES[image])
    assert not detection and detection.reason


def test_an_opencv_failure_is_a_reason():
    import cv2

    from usvips.core.calibration_targets.kinds import _board

    def failing(self, grey):
        raise cv2.error("the detector gave up")

    with pytest.raises(cv2.error):  # a real OpenCV error first: its reason lingers on the exception class
        cv2.resize(np.zeros((0, 0), np.uint8), (3, 3))

    detection = _board.guarded(failing)(None, np.zeros((20, 30), np.uint8))
    assert not detection and detection.reason == "OpenCV could not search the image: the detector gave up"
    assert detection.image_size == (30, 20)


@pytest.mark.parametrize(("cols", "rows", "legacy"), [(6, 4, False), (7, 4, True), (6, 5, True)])
def test_a_charuco_board_described_wrongly_gives_no_corner_and_says_what_to_check(cols, rows, legacy):
    printed = kind("charuco")("4X4_50", 6, 4, 0.035, 0.026, legacy=True)
    image, _ = _view(printed, distance=0.45)
    assert printed.detect(image)
    detection = kind("charuco")("4X4_50", cols, rows, 0.035, 0.026, legacy=legacy).detect(image)
    assert not detection and "check the squares" in detection.reason and "legacy" in detection.reason


def test_a_large_image_is_searched_reduced_and_refined_at_full_resolution():
    """A 2,800 × 2,100 still (searched at half size): every corner within 0.15 px of its true place."""
    import cv2

    from usvips.core.calibration_targets.kinds.chessboard import SEARCH_SIDE_PX

    board = kind("chessboard")(9, 6, 0.024)
    per_metre = 5000.0
    x0, y0, x1, y1 = board.sheet()
    width, height = int((x1 - x0) * per_metre), int((y1 - y0) * per_metre)
    rows, cols = np.mgrid[0:height, 0:width]
    xy = np.column_stack([(cols.ravel() + 0.5) / per_metre + x0, (rows.ravel() + 0.5) / per_metre + y0])
    art = (215.0 - 185.0 * board.ink(xy)).reshape(height, width).astype(np.float32)
    corners = np.float32([[0, 0], [width, 0], [width, height], [0, height]])
    placed = np.float32([[700, 500], [2100, 620], [2000, 1700], [780, 1560]])
    homography = cv2.getPerspectiveTransform(corners - 0.5, placed - 0.5)  # pixel centres to pixel centres
    image = cv2.warpPerspective(art, homography, (2800, 2100), flags=cv2.INTER_AREA, borderValue=100.0)
    image = np.clip(np.rint(cv2.GaussianBlur(image, (0, 0), 1.0)), 0, 255).astype(np.uint8)
    assert max(image.shape) > SEARCH_SIDE_PX
    ids, points = board.points()
    raster = (points - (x0, y0)) * per_metre - 0.5
    truth = cv2.perspectiveTransform(raster.reshape(-1, 1, 2), homography).reshape(-1, 2)
    detection = board.detect(image)
    assert detection and detection.ids == ids
    assert np.linalg.norm(detection.pixels - truth, axis=1).max() < 0.15
