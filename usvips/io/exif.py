"""Capture time from a JPEG's EXIF (``DateTimeOriginal`` with ``SubSecTimeOriginal``), read from the
file's APP1 segment without an imaging library. Times are naive datetimes (the camera's clock)."""

from __future__ import annotations

import struct
from datetime import datetime
from pathlib import Path

from usvips.core.errors import InputFileError

_EXIF_IFD = 0x8769
_DATETIME_ORIGINAL = 0x9003
_SUBSEC_ORIGINAL = 0x9291
_DATETIME = 0x0132


def _app1(data: bytes) -> bytes | None:
    if data[:2] != b"\xff\xd8":
        return None
    at = 2
    while at + 4 <= len(data) and data[at] == 0xFF:
        marker = data[at + 1]
        length = struct.unpack(">H", data[at + 2:at + 4])[0]
        if marker == 0xE1 and data[at + 4:at + 10] == b"Exif\x00\x00":
            return data[at + 10:at + 2 + length]
        if marker == 0xDA:  # start of scan: no more metadata
            return None
        at += 2 + length
    return None


def _ifd(tiff: bytes, offset: int, order: str) -> dict[int, bytes | int]:
    """Tags of one IFD: ASCII values as bytes, LONG/SHORT values as int."""
    count = struct.unpack(order + "H", tiff[offset:offset + 2])[0]
    tags: dict[int, bytes | int] = {}
    for k in range(count):
        entry = tiff[offset + 2 + 12 * k: offset + 14 + 12 * k]
        tag, kind, n = struct.unpack(order + "HHI", entry[:8])
        if kind == 2:  # ASCII
            start = struct.unpack(order + "I", entry[8:12])[0] if n > 4 else offset + 2 + 12 * k + 8
            tags[tag] = tiff[start:start + n].rstrip(b"\x00 ")
        elif kind == 4:
            tags[tag] = struct.unpack(order + "I", entry[8:12])[0]
        elif kind == 3:
            tags[tag] = struct.unpack(order + "H", entry[8:10])[0]
    return tags


class DamagedExifError(InputFileError):
    """A JPEG's EXIF is there but cannot be read: a damaged file, unlike one without a capture time."""


#: what cameras whose clock was never set write as the capture time: no time, not a damaged one
_UNSET_STAMP = frozenset(b"0: ")


def capture_time(path: str | Path) -> datetime:
    """The capture time of a JPEG; a file without it is named (:class:`DamagedExifError` when its EXIF
    cannot be read)."""
    path = Path(path)
    with open(path, "rb") as stream:
        data = stream.read(1 << 17)  # EXIF lives in the first 64 KB segment
    tiff = _app1(data)
    if tiff is None or len(tiff) < 8 or tiff[:2] not in (b"II", b"MM"):
        raise InputFileError(str(path), "no EXIF capture time (not a JPEG with EXIF)")
    order = "<" if tiff[:2] == b"II" else ">"
    try:
        main = _ifd(tiff, struct.unpack(order + "I", tiff[4:8])[0], order)
        exif = _ifd(tiff, int(main[_EXIF_IFD]), order) if _EXIF_IFD in main else {}
        stamp = exif.get(_DATETIME_ORIGINAL) or main.get(_DATETIME)
        if not stamp:
            raise InputFileError(str(path), "the EXIF holds no capture time (DateTimeOriginal)")
        if isinstance(stamp, bytes) and set(stamp) <= _UNSET_STAMP:
            raise InputFileError(str(path), f"the EXIF capture time is unset ({stamp.decode('ascii')!r}: the "
                                 "camera's clock was not set)")
        when = datetime.strptime(stamp.decode("ascii"), "%Y:%m:%d %H:%M:%S")
        subsec = exif.get(_SUBSEC_ORIGINAL)
        if subsec and subsec.decode("ascii").isdigit():
            digits = subsec.decode("ascii")
            when = when.replace(microsecond=int(round(int(digits) / 10 ** len(digits) * 1e6)) % 1_000_000)
        return when
    except (struct.error, ValueError, UnicodeDecodeError, KeyError) as error:
        raise DamagedExifError(str(path), f"damaged EXIF ({error})") from None


def exif_jpeg(jpeg: bytes, when: datetime) -> bytes:
    """``jpeg`` with an EXIF segment stating ``when`` as DateTimeOriginal (+ SubSecTimeOriginal in ms);
    for tests and for writing exported frames with their time."""
    stamp = when.strftime("%Y:%m:%d %H:%M:%S").encode() + b"\x00"
    subsec = f"{when.microsecond // 1000:03d}".encode() + b"\x00"
    # little-endian TIFF: IFD0 (1 entry: ExifIFD pointer) at 8, Exif IFD (2 entries) at 26, values after
    exif_ifd = 8 + 2 + 12 + 4
    values = exif_ifd + 2 + 2 * 12 + 4
    tiff = b"II*\x00" + struct.pack("<I", 8)
    tiff += struct.pack("<H", 1) + struct.pack("<HHII", _EXIF_IFD, 4, 1, exif_ifd) + struct.pack("<I", 0)
    tiff += struct.pack("<H", 2) + struct.pack("<HHII", _DATETIME_ORIGINAL, 2, len(stamp), values)
    tiff += struct.pack("<HHI", _SUBSEC_ORIGINAL, 2, len(subsec)) + subsec.ljust(4, b"\x00")
    tiff += struct.pack("<I", 0) + stamp
    segment = b"Exif\x00\x00" + tiff
    return jpeg[:2] + b"\xff\xe1" + struct.pack(">H", len(segment) + 2) + segment + jpeg[2:]
