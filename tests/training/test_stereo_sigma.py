"""The [stereo_sigma] table measured by usvips.training.stereo_sigma: the fit recovers the sizes' sigma from
errors of known sigma, the table written is the table read back, and the run never writes over its input.
(The fit itself, gross misses included, is tested over many random cases in
tests/core/detection/test_keypoint_sigma.py.)"""

import numpy as np
import pytest

from usvips.io.model_description import read_model_description
from usvips.training.stereo_sigma import KEYPOINTS, StereoErrors, fit_stereo_sigma, main, stereo_sigma_table

DESCRIPTION = """
[model]
file = "fish.onnx"
family = "yolo-pose"
input_width = 320
input_height = 320

[output]
classes = ["fish"]
keypoints = ["snout", "fork"]
"""


def _errors(rng: np.random.Generator, left: dict, match: dict, scale: float, count: int = 600) -> StereoErrors:
    errors = StereoErrors()
    for name in KEYPOINTS:
        size = rng.uniform(20, 300, count)
        a, b = left[name]
        errors.left_size[name] = list(size)
        errors.left_error[name] = list(rng.normal(size=(count, 2)) * np.sqrt(a ** 2 + (b * size * scale) ** 2)[:, None]
                                       / scale)
        a, b = match[name]
        errors.match_size[name] = list(size)
        errors.match_error[name] = list(rng.normal(size=(count, 2)) * np.sqrt(a ** 2 + (b * size) ** 2)[:, None])
        errors.unmatched_size[name] = list(size[:100])
        errors.unmatched_error[name] = list(rng.normal(size=(100, 2)) * 3.0)
    return errors


def test_the_fitted_table_is_the_sigma_the_errors_have_and_reads_back(tmp_path):
    rng = np.random.default_rng(8)
    left, match = {"snout": (0.8, 0.01), "fork": (0.6, 0.04)}, {"snout": (0.4, 0.0), "fork": (0.3, 0.006)}
    stereo = fit_stereo_sigma(_errors(rng, left, match, 0.5), 0.5, 'rendered "clips"')
    for name in KEYPOINTS:
        assert stereo.left[name](100.0) == pytest.approx(np.hypot(left[name][0], left[name][1] * 100), rel=0.1)
        assert stereo.match[name](150.0) == pytest.approx(np.hypot(match[name][0], match[name][1] * 150), rel=0.1)
        assert stereo.unmatched[name](100.0) == pytest.approx(1.5, rel=0.2)  # 3 image px at scale 0.5
    path = tmp_path / "fish.toml"
    path.write_text(DESCRIPTION + stereo_sigma_table(stereo))
    read = read_model_description(path).stereo_sigma
    assert read.basis == 'rendered "clips"'
    for name in KEYPOINTS:
        assert read.left[name](50.0) == pytest.approx(stereo.left[name](50.0), rel=1e-3)
        assert read.match[name](50.0) == pytest.approx(stereo.match[name](50.0), rel=1e-3)
        assert read.unmatched[name](50.0) == pytest.approx(stereo.unmatched[name](50.0), rel=1e-3)


def test_the_collected_errors_are_kept_and_read_back(tmp_path):
    errors = _errors(np.random.default_rng(2), {"snout": (1, 0), "fork": (1, 0)}, {"snout": (1, 0), "fork": (1, 0)},
                     0.5, 30)
    errors.clips, errors.pairs = 3, 30
    errors.save(tmp_path / "errors.npz")
    read = StereoErrors.load(tmp_path / "errors.npz")
    assert (read.clips, read.pairs) == (3, 30)
    for name in KEYPOINTS:
        assert np.array_equal(np.array(read.match_error[name]), np.array(errors.match_error[name]))
        assert np.array_equal(np.array(read.unmatched_size[name]), np.array(errors.unmatched_size[name]))


def test_the_run_never_writes_over_its_input(tmp_path, capsys):
    path = tmp_path / "fish.toml"
    path.write_text(DESCRIPTION)
    assert main(["--model", str(path), "--seeds", "1", "1", "--out", str(path)]) == 2
    assert "write over" in capsys.readouterr().err and path.read_text() == DESCRIPTION


def test_a_refit_replaces_the_descriptions_table_and_keeps_the_rest(tmp_path):
    """A description that has a [stereo_sigma] table is refitted (its table sets refinement's limits while
    the errors are collected): the output holds the new table only, every other table as it was."""
    from usvips.training.stereo_sigma import without_stereo_sigma

    rng = np.random.default_rng(9)
    old = fit_stereo_sigma(_errors(rng, {"snout": (1.0, 0.01), "fork": (1.0, 0.02)},
                                   {"snout": (0.3, 0.0), "fork": (0.3, 0.01)}, 0.5), 0.5, "old clips")
    new = fit_stereo_sigma(_errors(rng, {"snout": (2.0, 0.01), "fork": (2.0, 0.02)},
                                   {"snout": (0.6, 0.0), "fork": (0.6, 0.01)}, 0.5), 0.5, "new clips")
    with_old = DESCRIPTION + stereo_sigma_table(old) + '\n[validation]\nsource = "held-out frames"\n'
    refitted = without_stereo_sigma(with_old).rstrip("\n") + "\n" + stereo_sigma_table(new)
    assert refitted.count("[stereo_sigma]") == 1 and "old clips" not in refitted and "held-out frames" in refitted
    path = tmp_path / "fish.toml"
    path.write_text(refitted, encoding="utf-8")
    read = read_model_description(path).stereo_sigma
    assert read.basis == "new clips"
    assert read.left["snout"].a == pytest.approx(new.left["snout"].a, rel=1e-3)
    assert without_stereo_sigma(DESCRIPTION) == DESCRIPTION
