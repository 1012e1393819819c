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


def _png_header(width: int, height: int) -> bytes:
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
            + chunk(b"IEND", b""))


def test_a_huge_declared_size_is_refused_before_decoding_and_the_limit_can_be_raised(tmp_path, monkeypatch):
    from usvips.io.images import MAX_PIXELS_VARIABLE

    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(_png_header(30000, 30000))
    with pytest.raises(InputFileError, match="declares 30000 × 30000 pixels"):
        read_image(bomb)
    small = tmp_path / "small.png"
    write_image(small, np.zeros((40, 50), np.uint8))
    monkeypatch.setenv(MAX_PIXELS_VARIABLE, "1000")
    with pytest.raises(InputFileError, match="declares 50 × 40 pixels.*USVIPS_MAX_IMAGE_PIXELS"):
        read_image(small)
    monkeypatch.setenv(MAX_PIXELS_VARIABLE, "2000")
    assert read_image(small).shape == (40, 50)


@pytest.mark.parametrize("suffix", [".png", ".jpg", ".bmp", ".tif", ".ppm", ".pgm", ".webp"])
def test_the_declared_size_is_read_from_every_common_header(tmp_path, suffix):
    import cv2

    from usvips.io.images import declared_size

    rng = np.random.default_rng(len(suffix))
    for _ in range(5):
        height, width = (int(v) for v in rng.integers(1, 300, 2))
        image = rng.integers(0, 255, (height, width) if suffix == ".pgm" else (height, width, 3), dtype=np.uint8)
        ok, encoded = cv2.imencode(suffix, image)
        assert ok and declared_size(encoded.tobytes()) == (width, height)
