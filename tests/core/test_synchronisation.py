"""Synchronisation estimators against known offsets: many random flashes and soundtracks (sub-frame
offsets, noise), and the rov_flatport video's lag from its images (also trimmed to other lags)."""

from pathlib import Path

import numpy as np
import pytest

from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.synchronisation import audio_offset, flash_offset, image_offset

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
