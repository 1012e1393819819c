"""The board renderer: poses land where asked through every housing, the printed pattern is drawn where
the camera model puts it, blur and noise behave, bad input is named."""

import numpy as np
import pytest

from tests.core.scenes import HOUSINGS
from usvips.core.calibration_targets import kind
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InvalidParameterError
from usvips.core.interior import Interior
from usvips.core.synth.boards import BoardPose, _line_kernel, board_pixels, render_board

W, H = 240, 180


def _camera(housing="air"):
    return Camera(Interior(f=260.0, xp=120.3, yp=88.9, k1=-0.03), Exterior(0.02, -0.01, 0.0, 0.03, -0.02, 0.1),
                  HOUSINGS[housing], W, H)


@pytest.mark.parametrize("housing", ["air", "flat-port", "dome-port", "dome-cover"])
def test_a_pose_facing_a_pixel_puts_the_board_point_on_that_pixel(housing):
    camera = _camera(housing)
    rng = np.random.default_rng(4)
    for _ in range(5):
        pixel = (rng.uniform(40, 200), rng.uniform(30, 150))
        pose = BoardPose.facing(camera, (0.05, 0.03), pixel, rng.uniform(0.3, 1.5), tilt=rng.uniform(0, 1),
                                tilt_direction=rng.uniform(0, 6), spin=rng.uniform(-3, 3))
        point = pose.to_object(np.array([[0.05, 0.03, 0.0]]))
        np.testing.assert_allclose(camera.project(point).pixels[0], pixel, atol=1e-6)


def test_an_untilted_board_faces_the_camera_upright():
    camera = _camera()
    board = kind("chessboard")(9, 6, 0.02)
    pose = BoardPose.facing(camera, (0.08, 0.05), (120, 90), 0.6)
    _, pixels, ok = board_pixels(camera, board, pose)
    assert ok.all()
    grid = pixels.reshape(6, 9, 2)
    along_x, along_y = grid[0, -1] - grid[0, 0], grid[-1, 0] - grid[0, 0]
    assert along_x[0] > 0 and abs(along_x[1]) < 0.2 * along_x[0]  # the board's x runs right in the image
    assert along_y[1] > 0 and abs(along_y[0]) < 0.2 * along_y[1]  # and its y down


@pytest.mark.parametrize("housing", ["air", "flat-port", "dome-port"])
def test_the_pattern_is_drawn_where_the_camera_model_puts_it(housing):
    """Sampled far from any edge, each square's pixel has the square's printed grey: the ray tracing and
    the pattern agree with back-projection of the square's centre."""
    camera = _camera(housing)
    board = kind("chessboard")(9, 6, 0.02)
    pose = BoardPose.facing(camera, (0.08, 0.05), (120, 90), 0.55, tilt=0.4, tilt_direction=1.0, spin=0.5)
    image = render_board(camera, board, pose, supersample=2, blur=0.0, noise=0.0)
    b, a = np.mgrid[0:7, 0:10]
    centres = np.column_stack([(a.ravel() - 0.5) * 0.02, (b.ravel() - 0.5) * 0.02, np.zeros(a.size)])
    pixels = camera.project(pose.to_object(centres)).pixels
    levels = image[np.rint(pixels[:, 1]).astype(int), np.rint(pixels[:, 0]).astype(int)]
    black = board.ink(centres[:, :2]) == 1
    assert np.all(levels[black] == 30) and np.all(levels[~black] == 215)


def test_the_background_is_where_the_board_is_not():
    camera = _camera()
    board = kind("chessboard")(5, 4, 0.01)
    pose = BoardPose.facing(camera, (0.02, 0.015), (120, 90), 1.0)
    image = render_board(camera, board, pose, supersample=1, blur=0.0, noise=0.0, background=77.0)
    assert image[0, 0] == 77 and image[-1, -1] == 77


def test_noise_blur_and_bit_depth():
    camera = _camera()
    board = kind("chessboard")(9, 6, 0.02)
    pose = BoardPose.facing(camera, (0.08, 0.05), (120, 90), 0.6)
    clean = render_board(camera, board, pose, supersample=2, noise=0.0).astype(float)
    noisy = render_board(camera, board, pose, supersample=2, noise=3.0, seed=1).astype(float)
    assert 2.5 < np.std(noisy - clean) < 3.5
    again = render_board(camera, board, pose, supersample=2, noise=3.0, seed=1).astype(float)
    assert np.array_equal(noisy, again)
    deep = render_board(camera, board, pose, supersample=2, noise=0.0, dtype=np.uint16)
    assert deep.dtype == np.uint16 and np.abs(deep / 257.0 - clean).max() <= 0.51
    colour = render_board(camera, board, pose, supersample=2, noise=0.0, colour=True)
    assert colour.shape == (H, W, 3)


@pytest.mark.parametrize(("length", "angle"), [(5.0, 0.0), (9.0, 0.7), (12.0, np.pi / 2)])
def test_the_motion_kernel_is_a_normalised_segment_of_that_length(length, angle):
    kernel = _line_kernel(length, angle)
    assert kernel.sum() == pytest.approx(1.0)
    ys, xs = np.nonzero(kernel > 0.02 * kernel.max())
    centre = (kernel.shape[0] - 1) / 2
    along = (xs - centre) * np.cos(angle) + (ys - centre) * np.sin(angle)
    across = -(xs - centre) * np.sin(angle) + (ys - centre) * np.cos(angle)
    assert along.max() - along.min() == pytest.approx(length, abs=1.6)
    assert np.abs(across).max() < 1.5


def test_bad_poses_and_sizes_are_named():
    with pytest.raises(InvalidParameterError, match="rotation"):
        BoardPose(np.diag([1.0, 1.0, -1.0]), (0, 0, 1))
    with pytest.raises(InvalidParameterError, match="position"):
        BoardPose(np.eye(3), (0, np.nan, 1))
    camera = Camera(Interior(f=260.0, xp=120.0, yp=90.0), Exterior(0, 0, 0))
    board = kind("chessboard")(5, 4, 0.01)
    with pytest.raises(InvalidParameterError, match="size"):
        render_board(camera, board, BoardPose(np.eye(3), (0, 0, -1)))
    with pytest.raises(InvalidParameterError, match="supersample"):
        render_board(_camera(), board, BoardPose(np.eye(3), (0, 0, -1)), supersample=0)
