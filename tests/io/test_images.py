import numpy as np
import pytest

from usvips.core.errors import InputFileError
from usvips.io.images import read_image, write_image


def test_round_trip_grey_colour_and_16_bit(tmp_path):
    rng = np.random.default_rng(0)
    for image in (rng.integers(0, 256, (12, 10), dtype=np.uint8),
                  rng.integers(0, 256, (12, 10, 3), dtype=np.uint8),
                  rng.integers(0, 65536, (12, 10), dtype=np.uint16)):
        write_image(tmp_path / "a.png", image)
        np.testing.assert_array_equal(read_image(tmp_path / "a.png"), image)


@pytest.mark.parametrize("content, message", [(b"", "empty"), (b"not an image at all", "not an image")])
def test_empty_and_non_image_files_are_refused(tmp_path, content, message):
    path = tmp_path / "x.png"
    path.write_bytes(content)
    with pytest.raises(InputFileError, match=message):
        read_image(path)
    with pytest.raises(InputFileError, match="no such image file"):
        read_image(tmp_path / "missing.png")
    with pytest.raises(InputFileError, match="float64"):
        write_image(tmp_path / "f.png", np.zeros((3, 3)))
