"""Pairing a user's left and right images (or video files) given as folders or lists.

Three rules, tried in this order by :func:`pair_images` with ``by="auto"``:

- ``stem``: the files share a stem once the camera's mark is taken off (``IMG_0042_L.jpg`` ↔
  ``IMG_0042_R.jpg``, ``left/0042.png`` ↔ ``right/0042.png``, ``L0042`` ↔ ``R0042``);
- ``time``: the capture times in the JPEGs' EXIF, each left image with the right one taken nearest in
  time, within ``max_dt`` seconds (cameras triggered together; their clocks set alike);
- ``order``: the n-th left file (sorted by name, numbers compared as numbers) with the n-th right file;
  the two lists must then be as long as each other.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

from usvips.core.errors import InputFileError, InvalidParameterError, concerning
from usvips.io.exif import DamagedExifError, capture_time

#: how each pairing rule is named to a person
RULE_NAMES = {"stem": "shared stem", "time": "capture time", "order": "name order"}
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")
VIDEO_SUFFIXES = (".mp4", ".mov", ".avi", ".mkv", ".mts", ".m4v", ".webm")
_CAMERA_MARK = re.compile(r"(^|[_\-. ])(l|r|left|right|links|rechts|cam[12])($|[_\-. ])|^(l|r)(?=\d)",
                          re.IGNORECASE)


def natural_key(path: Path) -> list:
    """Sort key comparing runs of digits as numbers (``img2`` before ``img10``)."""
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", path.name)]


#: how messages name the files of each side (the ``parameter`` of :func:`expand`, :func:`check_chapters`)
SIDE_WORDS = {"left": "the left camera's files", "right": "the right camera's files"}


def expand(items: Sequence[str | Path], suffixes: Sequence[str], parameter: str) -> list[Path]:
    """Files of a list of files and folders (a folder gives its files with one of ``suffixes``, in
    natural order); a missing file or an empty folder is named, the error concerning ``parameter``
    (``left`` or ``right``)."""
    what = SIDE_WORDS.get(parameter, parameter)
    files: list[Path] = []
    for item in items:
        if not str(item).strip():  # Path("") is the working folder: an empty value would read it silently
            raise concerning(InvalidParameterError(parameter, f"{what}: an empty path; name a file or a folder"),
                             parameter)
        path = Path(item)
        if path.is_dir():
            found = sorted((p for p in path.iterdir() if p.is_file() and p.suffix.lower() in suffixes), key=natural_key)
            if not found:
                raise concerning(InputFileError(str(path), f"{what}: the folder holds no {'/'.join(suffixes)} files"),
                                 parameter)
            files.extend(found)
        elif path.is_file():
            files.append(path)
        else:
            raise concerning(InputFileError(str(path), f"{what}: no such file or folder"), parameter)
    if not files:
        raise concerning(InputFileError("(nothing)", f"{what}: no files given"), parameter)
    return files


def shared_stem(path: Path) -> str:
    """The file's stem without the camera's mark (``IMG_0042_L`` → ``img_0042``)."""
    return _CAMERA_MARK.sub(lambda m: (m.group(1) or "") if m.group(4) is None else "", path.stem).lower().strip("_-. ")


def pair_by_time(left: Sequence[Path], right: Sequence[Path], max_dt: float = 1.0) -> list[tuple[Path, Path]]:
    """Each left image with the right image captured nearest in time (EXIF), within ``max_dt`` seconds,
    each used once; in order of capture."""
    left_times = sorted((capture_time(p), p) for p in left)
    right_times = [(capture_time(p), p) for p in right]
    used: set[Path] = set()
    pairs = []
    for when, path in left_times:
        free = [(abs((t - when).total_seconds()), p) for t, p in right_times if p not in used]
        if not free or min(free)[0] > max_dt:
            raise InputFileError(str(path), f"no right image captured within {max_dt:g} s of it (EXIF time "
                                 f"{when.isoformat(sep=' ')})")
        partner = min(free)[1]
        used.add(partner)
        pairs.append((path, partner))
    if len(used) != len(right):
        extra = next(p for _, p in right_times if p not in used)
        raise InputFileError(str(extra), "no left image captured at its time: cannot pair by time")
    return pairs


def pair_images(left: Sequence[Path], right: Sequence[Path], by: str = "auto",
                max_dt: float = 1.0) -> tuple[list[tuple[Path, Path]], str]:
    """(left, right) pairs and the rule used (``stem``, ``time`` or ``order``)."""
    if by not in ("auto", "stem", "time", "order"):
        raise InvalidParameterError("pair_by", f"{by!r}: choose auto, stem, time or order", label="pairing rule")
    if by in ("auto", "stem"):
        left_stems = {shared_stem(p): p for p in left}
        right_stems = {shared_stem(p): p for p in right}
        unique = len(left_stems) == len(left) and len(right_stems) == len(right)
        if unique and left_stems.keys() == right_stems.keys():
            pairs = [(left_stems[s], right_stems[s]) for s in sorted(left_stems, key=lambda s: natural_key(Path(s)))]
            return pairs, "stem"
        if by == "stem":
            missing = sorted(set(left_stems) ^ set(right_stems))
            raise InputFileError(str(left[0].parent), f"cannot pair by stem: {len(missing)} file(s) without a partner, "
                                 f"e.g. {missing[0]!r}" if missing else "cannot pair by stem: stems repeat")
    if by == "time":
        return pair_by_time(left, right, max_dt), "time"
    if by == "auto" and all(p.suffix.lower() in (".jpg", ".jpeg") for p in (*left, *right)):
        try:
            return pair_by_time(left, right, max_dt), "time"
        except DamagedExifError as error:  # not paired silently by order with one image's time unread
            raise concerning(DamagedExifError(error.path, f"{error.problem}: capture times cannot pair these "
                                              "images; pair them by order to ignore capture times"),
                             "pair_by") from None
        except InputFileError:
            pass  # no usable capture times: by order below
    if len(left) != len(right):
        raise InputFileError(str(left[0].parent), f"cannot pair by order: {len(left)} left and {len(right)} right "
                             "files (and their stems do not match)")
    return list(zip(left, right, strict=True)), "order"


_GOPRO_CHAPTER = re.compile(r"^(G[HXP])(\d{2})(\d{4})$", re.IGNORECASE)


def check_chapters(files: Sequence[Path], parameter: str) -> None:
    """Chapters named as GoPro names them (``GX010042``, ``GX020042`` …: chapter, then recording number)
    must be of one recording, in order, with none missing; other names are taken in the order given.
    Errors concern ``parameter`` (``left`` or ``right``)."""
    option = SIDE_WORDS.get(parameter, parameter)
    parsed = [_GOPRO_CHAPTER.match(p.stem) for p in files]
    if len(files) < 2 or not all(parsed):
        return
    recordings = {m.group(3) for m in parsed}
    if len(recordings) > 1:
        raise concerning(InputFileError(str(files[0]), f"{option}: chapters of different recordings "
                                        f"({', '.join(sorted(recordings))}) given as one"), parameter)
    numbers = [int(m.group(2)) for m in parsed]
    for previous, (path, number, m) in zip(numbers, list(zip(files, numbers, parsed, strict=True))[1:], strict=False):
        if number <= previous:
            raise concerning(InputFileError(str(path), f"{option}: chapters out of order (chapter {number:02d} "
                                            f"after {previous:02d}); give them in recording order"), parameter)
        if number != previous + 1:
            missing = f"{m.group(1)}{previous + 1:02d}{m.group(3)}{path.suffix}"
            raise concerning(InputFileError(str(path), f"{option}: chapter {missing} is missing before it"),
                             parameter)
