"""Each enhancement against its definition, the pipeline's contract, histograms, bad input."""

import cv2
import numpy as np
import pytest

from usvips.core.enhance import Operation, Pipeline, balance_pair, histogram
from usvips.core.errors import InvalidParameterError


@pytest.fixture()
def grey():
    rng = np.random.default_rng(0)
    return rng.integers(20, 200, (40, 50), dtype=np.uint8)


@pytest.fixture()
def colour():
    rng = np.random.default_rng(1)
    return rng.integers(0, 256, (30, 40, 3), dtype=np.uint8)


def apply(image, name, **params):
    return Pipeline((Operation(name, params),)).apply(image)


def test_point_operations_follow_their_formulas(grey):
    np.testing.assert_array_equal(apply(grey, "brightness", offset=30), np.clip(grey.astype(int) + 30, 0, 255))
    expected = np.clip(np.rint(255 * (grey / 255.0) ** 0.5), 0, 255)
    np.testing.assert_array_equal(apply(grey, "gamma", gamma=0.5), expected)
    out = apply(grey, "piecewise", points=[[0, 0], [100, 200], [255, 255]])
    np.testing.assert_array_equal(out, np.clip(np.rint(np.interp(grey, [0, 100, 255], [0, 200, 255])), 0, 255))
    stretched = apply(grey, "linear_stretch", saturation=0.0)
    assert stretched.min() == 0 and stretched.max() == 255
    np.testing.assert_array_equal(apply(grey, "levels", gain=2.0, offset=-10),
                                  np.clip(grey.astype(int) * 2 - 10, 0, 255))


def test_equalisation_flattens_the_cumulative_histogram():
    rng = np.random.default_rng(2)
    dark = np.clip(rng.normal(60, 15, (200, 200)), 0, 255).astype(np.uint8)
    out = apply(dark, "equalize")
    np.testing.assert_array_equal(out, cv2.equalizeHist(dark))
    cdf = np.cumsum(np.bincount(out.ravel(), minlength=256)) / out.size
    assert np.max(np.abs(cdf - np.linspace(0, 1, 256))) < 0.05
    dark16 = (dark.astype(np.uint16) * 257)
    cdf16 = np.sort(apply(dark16, "equalize").ravel()) / 65535.0
    assert np.max(np.abs(cdf16 - np.linspace(0, 1, cdf16.size))) < 0.05


def test_filters_match_opencv_and_their_definitions(grey):
    np.testing.assert_array_equal(apply(grey, "median", size=3), cv2.medianBlur(grey, 3))
    np.testing.assert_array_equal(apply(grey, "mean", size=3),
                                  np.rint(cv2.blur(grey.astype(np.float32), (3, 3),
                                                   borderType=cv2.BORDER_REFLECT)).astype(np.uint8))
    kernel = [[0, 0, 0], [0, 1, 0], [0, 0, 0]]
    np.testing.assert_array_equal(apply(grey, "convolve", kernel=kernel), grey)
    flat = np.full((9, 9), 100, np.uint8)
    assert np.array_equal(apply(flat, "sobel", strength=3.0), flat)      # no edges, nothing added
    assert np.array_equal(apply(flat, "laplacian", strength=3.0), flat)
    step = np.zeros((9, 9), np.uint8)
    step[:, 5:] = 100
    assert apply(step, "sobel", strength=1.0)[4, 5] > 100                 # the edge is enhanced


def test_knn_removes_an_isolated_spike_and_keeps_an_edge():
    image = np.zeros((9, 9), np.uint8)
    image[:, 5:] = 200
    image[2, 2] = 255  # isolated noise
    out = apply(image, "knn", k=4)
    assert out[2, 2] < 60                      # the spike is averaged with its most similar neighbours
    assert out[6, 4] == 0 and out[6, 5] == 200  # the edge stays sharp


def test_colour_operations(colour):
    tinted = (colour.astype(float) * [1.0, 0.8, 0.6]).astype(np.uint8)
    balanced = apply(tinted, "white_balance")
    means = balanced.reshape(-1, 3).mean(axis=0)
    assert np.ptp(means) < 3.0
    with pytest.raises(InvalidParameterError, match="needs a colour image"):
        apply(colour[:, :, 0], "white_balance")
    assert apply(colour, "clahe").shape == colour.shape
    assert apply(colour.astype(np.uint16) * 257, "equalize").dtype == np.uint16


def test_pipeline_is_pure_and_round_trips_json(grey):
    pipeline = Pipeline().then("clahe", clip_limit=3).then("gamma", gamma=0.8).then("median", size=5)
    before = grey.copy()
    out = pipeline.apply(grey)
    np.testing.assert_array_equal(grey, before)              # the original is never modified
    assert out.shape == grey.shape and out.dtype == grey.dtype
    again = Pipeline.from_json(pipeline.to_json())
    assert again == pipeline
    np.testing.assert_array_equal(again.apply(grey), out)
    assert Pipeline().apply(grey) is not grey


def test_stereo_brightness_balancing(grey):
    right = (grey * 0.6 + 20).astype(np.uint8)
    balanced = Pipeline((balance_pair(grey, right),)).apply(right)
    assert abs(balanced.mean() - grey.mean()) < 1.0 and abs(balanced.std() - grey.std()) < 1.0


def test_histograms_per_channel(colour):
    counts, edges = histogram(colour, 256)
    assert counts.shape == (3, 256) and counts.sum(axis=1).tolist() == [colour.shape[0] * colour.shape[1]] * 3
    np.testing.assert_array_equal(counts[1], np.bincount(colour[:, :, 1].ravel(), minlength=256))
    counts16, edges16 = histogram(colour.astype(np.uint16) * 257, 64)
    assert counts16.shape == (3, 64) and edges16[-1] == 65536


@pytest.mark.parametrize("build, message", [
    (lambda: Operation("convolve", {"kernel": [[1, 1], [1, 1]]}), "convolve.kernel: must be odd-sized"),
    (lambda: Operation("gamma", {"gamma": 0}), "gamma.gamma"),
    (lambda: Operation("median", {"size": 4}), "median.size: must be odd"),
    (lambda: Operation("sharpen", {}), "unknown enhancement 'sharpen'"),
    (lambda: Operation("gamma", {"gama": 2}), "unknown parameter"),
    (lambda: Pipeline.from_json("[{"), "not valid JSON"),
])
def test_bad_parameters_name_the_operation(build, message):
    with pytest.raises(InvalidParameterError, match=message):
        build()


def test_unsupported_images_are_refused():
    with pytest.raises(InvalidParameterError, match="unsupported pixel type float64"):
        Pipeline().apply(np.zeros((4, 4)))
    with pytest.raises(InvalidParameterError, match="shape"):
        Pipeline().apply(np.zeros((4, 4, 4), np.uint8))
    with pytest.raises(InvalidParameterError, match="outside"):
        apply(np.zeros((4, 4, 3), np.uint8), "white_balance", method="patch", patch=[0, 0, 9, 9])


def test_clahe_is_opencvs_on_grey_and_16_bit(grey):
    expected = cv2.createCLAHE(clipLimit=3.0, tileGridSize=(4, 4)).apply(grey)
    np.testing.assert_array_equal(apply(grey, "clahe", clip_limit=3.0, tiles=4), expected)
    wide = grey.astype(np.uint16) * 257
    np.testing.assert_array_equal(apply(wide, "clahe", clip_limit=3.0, tiles=4),
                                  cv2.createCLAHE(clipLimit=3.0, tileGridSize=(4, 4)).apply(wide))
