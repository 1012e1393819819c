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


def _smooth_picture(rng, height=120, width=160):
    import cv2

    return cv2.GaussianBlur((rng.random((height, width, 3)) * 255).astype(np.uint8), (0, 0), 2)


def test_valid_jpegs_of_every_common_kind_are_read_strictly(tmp_path):
    """Baseline and progressive, optimised or not, 4:4:4 / 4:2:2 / 4:2:0, grey, CMYK, restart markers,
    data after the end of the image (a camera's trailer, a second embedded JPEG): none is called damaged."""
    import io

    import cv2
    from PIL import Image

    from usvips.io.images import jpeg_damage

    rng = np.random.default_rng(11)
    picture = _smooth_picture(rng)
    variants = []
    for quality in (10, 75, 100):
        for progressive in (0, 1):
            for optimise in (0, 1):
                variants.append(cv2.imencode(".jpg", picture, [cv2.IMWRITE_JPEG_QUALITY, quality,
                                                               cv2.IMWRITE_JPEG_PROGRESSIVE, progressive,
                                                               cv2.IMWRITE_JPEG_OPTIMIZE, optimise])[1].tobytes())
    variants.append(cv2.imencode(".jpg", picture[:, :, 0], [cv2.IMWRITE_JPEG_RST_INTERVAL, 3])[1].tobytes())
    for subsampling in (0, 1, 2):
        for mode in ("L", "RGB", "CMYK"):
            stream = io.BytesIO()
            Image.fromarray(picture).convert(mode).save(stream, "JPEG", quality=90, subsampling=subsampling)
            variants.append(stream.getvalue())
    variants += [variants[0] + bytes(3000), variants[1] + b"camera trailer" * 40, variants[2] + variants[3]]
    for k, data in enumerate(variants):
        assert jpeg_damage(data) is None, k
        (tmp_path / f"{k}.jpg").write_bytes(data)
        assert read_image(tmp_path / f"{k}.jpg", strict=True).shape[:2] == (120, 160)


def test_a_jpeg_whose_compressed_data_is_damaged_is_refused_when_added(tmp_path):
    """Bytes overwritten inside the compressed data: OpenCV alone returns a partly wrong picture; a strict
    read refuses every such file a decoder can tell, naming it. (JPEG has no checksum: damage that still
    decodes as valid data is found by no decoder, so not every overwritten file is caught.)"""
    import cv2

    rng = np.random.default_rng(12)
    good = cv2.imencode(".jpg", _smooth_picture(rng, 240, 320), [cv2.IMWRITE_JPEG_QUALITY, 90])[1].tobytes()
    start_of_scan = good.index(b"\xff\xda")
    refused = 0
    for k in range(40):
        damaged = bytearray(good)
        at = int(rng.integers(start_of_scan + 200, len(good) - 100))
        damaged[at:at + 40] = rng.integers(0, 256, 40, dtype=np.uint8).tobytes()
        path = tmp_path / f"damaged{k}.jpg"
        path.write_bytes(bytes(damaged))
        assert read_image(path).shape == (240, 320, 3)  # OpenCV conceals it
        try:
            read_image(path, strict=True)
        except InputFileError as error:
            assert str(error).startswith(f"{path}: the JPEG's compressed data is damaged")
            assert "\n" not in str(error)
            refused += 1
    assert refused >= 5  # about a quarter of such files (the rest decode without an error anywhere)
    cut = tmp_path / "cut.jpg"
    cut.write_bytes(good[:len(good) // 2] + b"\xff\xd9")  # cut in the compressed data, then an end marker
    with pytest.raises(InputFileError, match="cut.jpg: the JPEG's compressed data is damaged"):
        read_image(cut, strict=True)

