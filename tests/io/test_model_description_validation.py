"""A model description's optional [validation] table: the pointing σ per keypoint measured on held-out data
is read into the description; a wrong count or value is one line naming the file and the key."""

import pytest

from usvips.core.errors import InputFileError
from usvips.io.model_description import read_model_description

HEAD = """[model]
file = "m.onnx"
family = "centre-pose"
input_width = 256
input_height = 256
[output]
classes = ["fish"]
keypoints = ["snout", "fork"]
"""


def test_the_measured_sigma_is_read_per_keypoint(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text(HEAD + '[validation]\nkeypoint_sigma = [0.8, 1.25]\nrecall = 0.93\nprecision = 0.97\n'
                           'median_error = [0.7, 1.1]\nsource = "rendered fish"\n')
    assert read_model_description(path).validated_keypoint_sigma == (0.8, 1.25)
    plain = tmp_path / "plain.toml"
    plain.write_text(HEAD)
    assert read_model_description(plain).validated_keypoint_sigma == ()


@pytest.mark.parametrize("line,key", [("keypoint_sigma = [0.8]", "validation.keypoint_sigma"),
                                      ("keypoint_sigma = [0.8, -1.0]", "validation.keypoint_sigma"),
                                      ("median_error = [0.8, 1.0, 2.0]", "validation.median_error"),
                                      ("recall = 1.5", "validation.recall"),
                                      ("sigma = 1.0", "validation.sigma")])
def test_a_wrong_validation_value_names_its_key(tmp_path, line, key):
    path = tmp_path / "m.toml"
    path.write_text(HEAD + "[validation]\n" + line + "\n")
    with pytest.raises(InputFileError, match=key.replace(".", r"\.")):
        read_model_description(path)
