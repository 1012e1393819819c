"""Synchronisation estimators against known offsets: many random flashes and soundtracks (sub-frame
offsets, noise), and the rov_flatport video's lag from its images (also trimmed to other lags)."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.synchronisation import audio_offset, flash_offset, image_offset, search_window

SAMPLE = Path(__file__).resolve().parents[2] / "sample_projects" / "rov_flatport"


def _exposed(times: np.ndarray, event: float, exposure: float, flash: float | None) -> np.ndarray:
    """Mean brightness of frames exposed over [t, t + exposure): a light switched on at ``event`` (s),
    or, with ``flash`` (s), on for that long."""
    on_start = np.clip(event - times, 0, exposure)
    lit = exposure - on_start
    if flash is not None:
        lit = np.clip(np.minimum(times + exposure, event + flash) - np.maximum(times, event), 0, None)
    return 50 + 150 * lit / exposure


def test_flash_offsets_are_found_to_a_fraction_of_a_frame_over_many_random_cases():
    rng = np.random.default_rng(11)
    errors = []
    for _ in range(200):
        fps = float(rng.choice([24, 25, 29.97, 30, 50, 60]))
        truth = rng.uniform(-40, 40)  # frames: right frame i + k shows left frame i's instant
        n = 300
        event = rng.uniform(60, 200) / fps
        exposure = rng.uniform(0.8, 1.0) / fps  # a long shutter: the change is caught inside an exposure
        flash = rng.choice([None, rng.uniform(2.0, 4.0) / fps])  # a light on for 2 frames or more
        left = _exposed(np.arange(n) / fps, event, exposure, flash)
        right = _exposed((np.arange(n) - truth) / fps, event, exposure, flash)
        noise = rng.uniform(0, 2)
        left, right = left + rng.normal(0, noise, n), right + rng.normal(0, noise, n)
        estimate = flash_offset(left, right, fps, max_offset=60)
        assert estimate.frames == round(truth) or abs(truth - round(truth)) > 0.3
        assert estimate.confidence > 0.3
        errors.append(estimate.offset_frames - truth)
    errors = np.abs(errors)
    assert np.percentile(errors, 90) < 0.35 and errors.max() < 0.6
    assert estimate.offset_s == pytest.approx(estimate.offset_frames / fps)


def test_audio_offsets_are_found_over_many_random_cases():
    rng = np.random.default_rng(5)
    rate = 8000
    for _ in range(40):
        fps = float(rng.choice([25, 29.97, 30, 60]))
        truth_s = rng.uniform(-1.5, 1.5)
        length = int(rate * 6)
        scene = rng.normal(0, 1, length + 4 * rate)  # the sound of the scene, heard by both
        start = 2 * rate
        shift = int(round(truth_s * rate))
        left = scene[start:start + length] + rng.normal(0, 0.5, length)
        right = scene[start - shift:start - shift + length] + rng.normal(0, 0.5, length)
        estimate = audio_offset(left, right, rate, fps, max_offset_s=2.0)
        assert estimate.offset_s == pytest.approx(shift / rate, abs=1.5 / rate)
        assert estimate.frames == round(shift / rate * fps)
        assert estimate.confidence > 0.5 and estimate.method == "audio"


def test_estimators_refuse_what_cannot_be_synchronised():
    with pytest.raises(DegenerateGeometryError, match="no brightness change"):
        flash_offset(np.full(50, 3.0), np.full(50, 3.0), 25)
    with pytest.raises(InvalidParameterError, match="fps"):
        flash_offset(np.arange(10.0), np.arange(10.0), 0)
    with pytest.raises(DegenerateGeometryError, match="silent"):
        audio_offset(np.zeros(8000), np.ones(8000), 8000, 25)


@pytest.fixture(scope="module")
def sample_video():
    from usvips.io.calibration_file import load_calibration
    from usvips.io.video_stream import VideoStream

    rig = load_calibration(SAMPLE / "calibration.json").rig(0, "rig")
    with VideoStream(SAMPLE / "video_left.avi") as left, VideoStream(SAMPLE / "video_right.avi") as right:
        frames = ([left.frame(i) for i in range(left.frame_count)], [right.frame(i) for i in range(right.frame_count)])
    return rig, frames


@pytest.mark.parametrize("trim_left, trim_right", [(0, 0), (2, 0), (0, 2), (0, 5)])
def test_the_sample_videos_lag_is_found_from_its_images(sample_video, trim_left, trim_right):
    """The sample's truth is k = 3; dropping a leading frames of the left video makes it k + a, of the
    right video k − a (offsets we did not render)."""
    rig, (left, right) = sample_video
    estimate = image_offset(left[trim_left:], right[trim_right:], rig.left, rig.right, 10, range(-6, 9), step=3)
    assert estimate.frames == 3 + trim_left - trim_right
    assert estimate.confidence > 0.3
    assert estimate.scores[estimate.frames] > max(v for k, v in estimate.scores.items() if k != estimate.frames)


# ---------------------------------------------------------------------------- sub-frame offsets from images
SYNTH_W, SYNTH_H = 320, 240
CELL = 0.02  # m: texture cell on the floor and the moving board


def _texture(grid: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    from scipy.ndimage import map_coordinates

    return map_coordinates(grid, [v / CELL + grid.shape[0] / 2, u / CELL + grid.shape[1] / 2], order=3,
                           mode="reflect")


def _synthetic_stereo_video(lag: float, rng: np.random.Generator, frames: int = 14, fps: float = 25.0,
                            angle: float | None = None):
    """Two flat-port cameras 0.3 m apart over a textured floor (1.8 m) with a textured board (0.35 m
    square, 1.1–1.4 m away) moving across at constant velocity. Left frame j shows instant j / fps, right
    frame j instant (j − lag) / fps: an offset of ``lag`` frames (fractional). ``angle`` (rad from the
    baseline): the board's direction of motion (default: random, at least 35° across the baseline).
    Returns the frames (grey) and the rig."""
    from usvips.core.camera import Camera, Exterior
    from usvips.core.housing import FlatPortHousing
    from usvips.core.interior import Interior
    from usvips.core.rig import RelativeOrientation, StereoRig

    interior = Interior(300.0, 160.0, 120.0, 1.0, k1=-0.03)
    housing = FlatPortHousing(0.02, -0.01, 0.05, 0.012, 1.5, 1.34)
    left = Camera(interior, Exterior(0.0, 0.0, 0.0), housing, SYNTH_W, SYNTH_H)
    rig = StereoRig.from_relative(left, left, RelativeOrientation(0.3, 0.0, 0.0, 0.0, -0.08, 0.0))
    floor_grid = rng.uniform(40, 200, (260, 260))
    board_grid = rng.uniform(20, 235, (40, 40))
    depth = float(rng.uniform(1.1, 1.4))
    # across the (nearly horizontal) epipolar lines: motion along them carries no timing
    if angle is None:
        angle = rng.uniform(np.radians(35), np.radians(145)) * rng.choice([-1, 1])
    speed = rng.uniform(0.15, 0.4) * np.array([np.cos(angle), np.sin(angle)])
    start = np.array([0.15, -0.05]) - speed * frames / fps / 2
    s = 2  # supersampling
    ys, xs = np.mgrid[0:SYNTH_H * s, 0:SYNTH_W * s]
    pixels = np.column_stack([(xs.ravel() + 0.5) / s - 0.5, (ys.ravel() + 0.5) / s - 0.5])
    videos = []
    for camera, shift in ((rig.left, 0.0), (rig.right, lag)):
        bundle = camera.rays(pixels)
        to_floor = (-1.8 - bundle.origins[:, 2]) / bundle.directions[:, 2]
        floor_hit = bundle.origins + to_floor[:, None] * bundle.directions
        floor = _texture(floor_grid, floor_hit[:, 0], floor_hit[:, 1])
        to_board = (-depth - bundle.origins[:, 2]) / bundle.directions[:, 2]
        board_hit = bundle.origins + to_board[:, None] * bundle.directions
        video = []
        for j in range(frames):
            centre = start + speed * (j - shift) / fps
            u, v = board_hit[:, 0] - centre[0], board_hit[:, 1] - centre[1]
            on = (np.abs(u) < 0.175) & (np.abs(v) < 0.175)
            values = np.where(on, _texture(board_grid, u, v), floor)
            image = values.reshape(SYNTH_H * s, SYNTH_W * s).reshape(SYNTH_H, s, SYNTH_W, s).mean(axis=(1, 3))
            image = image + rng.normal(0, 1.0, image.shape)
            video.append(np.clip(np.rint(image), 0, 255).astype(np.uint8))
        videos.append(video)
    return videos[0], videos[1], rig


SUBFRAME_TOLERANCE = 0.15  # frames, for estimates of confidence >= CONFIDENT
CONFIDENT = 0.3


@pytest.mark.parametrize("case", range(5))
def test_image_synchronisation_reports_a_sub_frame_offset_within_its_tolerance(case):
    """Random fractional lags, board speeds and directions: a confident sub-frame offset from the images
    (confidence >= 0.3) is within 0.15 frame of the truth and uses the nearest whole frame; a less
    confident one is still within 3 sigma (its sigma says how far to trust it); the sigma is honest
    (the error within 4 sigma, or 0.05 frame)."""
    rng = np.random.default_rng(100 + case)
    lag = float(rng.integers(-3, 4) + rng.uniform(-0.45, 0.45))
    left, right, rig = _synthetic_stereo_video(lag, rng)
    estimate = image_offset(left, right, rig.left, rig.right, 25.0, range(-4, 5), step=2, near=0.5, far=4.0)
    assert estimate.sigma_frames is not None and estimate.method == "image"
    error = abs(estimate.offset_frames - lag)
    assert error < max(4 * estimate.sigma_frames, 0.05), (lag, estimate)
    if estimate.confidence >= CONFIDENT:
        assert error < SUBFRAME_TOLERANCE, (lag, estimate)
        assert estimate.frames == int(np.round(lag))
        assert estimate.scores[estimate.frames] == max(estimate.scores.values())
    if estimate.rounded:
        assert f"using the nearest frame, {estimate.frames:+d}" in estimate.summary()
    assert estimate.as_dict()["offset_sigma_frames"] == pytest.approx(estimate.sigma_frames, abs=1e-3)


def test_image_synchronisation_without_motion_across_the_curves_says_so():
    """A board moving exactly along the (horizontal) epipolar lines carries no timing: the estimate is
    refused, or says it is not to be trusted (confidence below 0.3)."""
    rng = np.random.default_rng(7)
    left, right, rig = _synthetic_stereo_video(1.4, rng, angle=0.0)
    try:
        estimate = image_offset(left, right, rig.left, rig.right, 25.0, range(-4, 5), step=2, near=0.5, far=4.0)
    except DegenerateGeometryError:
        return
    assert estimate.confidence < CONFIDENT, estimate


def test_the_sigma_holds_the_calibration_error_that_every_feature_shares():
    """Curves from a calibration whose right principal point is 1.5 px off shift every feature's crossing
    alike: the votes agree with one another, not with the truth. Given that error as the curves' sigma
    (the calibration's pointing precision, in use), the estimate's sigma covers it; the votes' scatter
    alone would claim several times too much (as on the ROV sample: 3.17 ± 0.02 frames against 3)."""
    rng = np.random.default_rng(321)
    lag = float(rng.uniform(-2.4, 2.4))
    left, right, rig = _synthetic_stereo_video(lag, rng, angle=np.radians(80))
    wrong = replace(rig.right, interior=replace(rig.right.interior, yp=rig.right.interior.yp + 1.5))
    honest = image_offset(left, right, rig.left, wrong, 25.0, range(-4, 5), step=2, near=0.5, far=4.0,
                          epipolar_sigma_px=1.5)
    scatter_only = image_offset(left, right, rig.left, wrong, 25.0, range(-4, 5), step=2, near=0.5, far=4.0)
    assert honest.offset_frames == scatter_only.offset_frames
    error = abs(honest.offset_frames - lag)
    assert error < 3 * honest.sigma_frames, (lag, honest)
    assert error > 3 * scatter_only.sigma_frames, (lag, scatter_only)



# ---------------------------------------------------------------------------- estimates that know their limits
def _flash_case(rng: np.random.Generator, truth: float, fps: float, n: int = 300):
    event = rng.uniform(100, 200) / fps
    exposure = rng.uniform(0.8, 1.0) / fps
    flash = rng.choice([None, rng.uniform(2.0, 4.0) / fps])
    noise = rng.uniform(0, 2)
    left = _exposed(np.arange(n) / fps, event, exposure, flash) + rng.normal(0, noise, n)
    right = _exposed((np.arange(n) - truth) / fps, event, exposure, flash) + rng.normal(0, noise, n)
    return left, right


def _storable(estimate) -> bool:
    from usvips.app.video_project import store_refusal

    return store_refusal(estimate) is None


def test_a_flash_outside_the_window_is_never_stored_and_one_inside_is_over_many_random_cases():
    """Random lags and random windows (from the narrowest allowed to wide), half of them too narrow for the
    lag: an estimate that would be stored is always the true lag; a lag inside the window by two frames
    or more is found, inside the edge, and stored; a lag outside never is."""
    rng = np.random.default_rng(23)
    outside = inside = 0
    for _ in range(300):
        fps = float(rng.choice([24, 25, 29.97, 30, 50, 60]))
        window = search_window(int(rng.integers(int(np.ceil(0.5 * fps)), 60)), fps, 300)
        beyond = rng.random() < 0.5  # the lag outside the window, by 1.5 to 30 frames
        truth = rng.choice([-1, 1]) * (rng.uniform(window + 1.5, window + 30) if beyond else rng.uniform(0, window - 2))
        estimate = flash_offset(*_flash_case(rng, truth, fps), fps, max_offset=window)
        assert estimate.window == (-window, window)
        if _storable(estimate):
            assert estimate.frames == round(truth) or abs(truth - round(truth)) > 0.3, (truth, window, estimate)
        if abs(truth) <= window - 2:
            inside += 1
            assert not estimate.at_edge and _storable(estimate), (truth, window, estimate)
        elif abs(truth) > window + 1:
            outside += 1
            assert not _storable(estimate), (truth, window, estimate)
    assert inside > 100 and outside > 100  # both kinds were tried


def test_a_sound_outside_the_window_is_never_stored_over_many_random_cases():
    rng = np.random.default_rng(8)
    rate, length = 8000, 8000 * 6
    for _ in range(40):
        fps = float(rng.choice([25, 29.97, 30, 60]))
        truth_s = rng.uniform(-1.5, 1.5)
        window_s = rng.uniform(0.5, 2.0)
        scene = rng.normal(0, 1, length + 4 * rate)
        shift = int(round(truth_s * rate))
        left = scene[2 * rate:2 * rate + length] + rng.normal(0, 0.5, length)
        right = scene[2 * rate - shift:2 * rate - shift + length] + rng.normal(0, 0.5, length)
        estimate = audio_offset(left, right, rate, fps, max_offset_s=window_s)
        if abs(truth_s) < window_s - 1.5 / fps:
            assert not estimate.at_edge and _storable(estimate)
            assert estimate.offset_s == pytest.approx(shift / rate, abs=1.5 / rate)
        elif abs(truth_s) > window_s + 1 / fps:
            assert not _storable(estimate), (truth_s, window_s, estimate)


def test_a_search_of_one_candidate_has_no_confidence_and_is_at_its_edge():
    rng = np.random.default_rng(2)
    for truth in rng.uniform(-20, 20, 20):
        left, right = _flash_case(rng, truth, 25.0)
        estimate = flash_offset(left, right, 25.0, max_offset=0)
        assert estimate.confidence == 0 and estimate.at_edge and not _storable(estimate)
        for narrow in (1, 2):  # every other candidate inside the best one's own peak
            assert flash_offset(left, right, 25.0, max_offset=narrow).confidence == 0
    sound = rng.normal(0, 1, 16000)
    estimate = audio_offset(sound, np.roll(sound, 400), 8000, 25, max_offset_s=0)
    assert estimate.confidence == 0 and estimate.at_edge


def test_windows_are_whole_non_negative_and_wide_enough_for_a_lag():
    for bad in (-1, -300, 1.5, float("nan"), float("inf"), "x"):
        with pytest.raises(InvalidParameterError, match="max_offset"):
            search_window(bad, 25, 900)
        if not isinstance(bad, str):
            with pytest.raises(InvalidParameterError, match="max_offset"):
                flash_offset(np.arange(50.0) % 7, np.arange(50.0) % 7, 25, max_offset=bad)
    with pytest.raises(InvalidParameterError, match="max_offset_s"):
        audio_offset(np.ones(8000), np.ones(8000), 8000, 25, max_offset_s=-0.5)
    with pytest.raises(InvalidParameterError, match="cannot hold the lag"):
        search_window(0, 25, 900)
    with pytest.raises(InvalidParameterError, match="not smaller than the video"):
        search_window(900, 25, 900)
    assert search_window(None, 25, 900) == 300 and search_window(None, 25, 90) == 30
    assert search_window(13, 25, 900) == 13 and search_window(4, 25, 12) == 4  # a short video's whole third


def test_an_image_offset_at_the_edge_of_its_candidates_is_said_to_be(sample_video):
    rig, (left, right) = sample_video
    estimate = image_offset(left, right, rig.left, rig.right, 10, range(-6, 4), step=3)  # the truth, 3, at the edge
    assert estimate.at_edge and "edge of the search window" in estimate.edge_problem()
    inside = image_offset(left, right, rig.left, rig.right, 10, range(-6, 9), step=3)
    assert inside.frames == 3 and not inside.at_edge and inside.edge_problem() is None
