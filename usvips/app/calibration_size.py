"""The one check that a calibration fits the pictures it is used on: the same size in pixels.

A calibration's interior orientation (principal point, distortion, pixel pitch) holds for the frame size
it was made at; on pictures of another size (a cropped 600 × 440 pair under a 640 × 480 calibration, a
1080p video under a 640 × 480 one) every ray is wrong and nothing says so. So making a calibration active,
measuring, synchronising, taking a frame pair and importing all ask here, and refuse with one line naming
both sizes. The command line and the window call the same functions (the window shows the line).

A calibration records its frame size per camera (``width``/``height`` in pixels, see
:class:`usvips.core.camera.Camera`); one that records none (made before sizes were kept, or written by
hand without them) cannot be checked and is let through. A calibration made at one resolution is NOT
scaled to another: scaling would need the sensor's crop and binning, which a calibration does not hold;
make (or import) one at the pictures' size instead.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from usvips.app.calibrations import make_active, read_calibration
from usvips.core.errors import UsvipsError
from usvips.core.stereo_calibration import StereoCalibration
from usvips.io.calibration_file import calibration_from_dict
from usvips.io.images import declared_size
from usvips.store.interface import ProjectStore


class SizeMismatchError(UsvipsError):
    """Pictures of another size (pixels) than the calibration used on them was made at."""


def calibration_size(calibration: StereoCalibration) -> tuple[int, int] | None:
    """(width, height) in pixels the calibration was made at (its left camera's frame), or None when it
    does not record one. Left and right recording different sizes is itself refused."""
    left = (calibration.left.width, calibration.left.height)
    right = (calibration.right.width, calibration.right.height)
    if None in left or None in right:
        known = left if None not in left else right if None not in right else None
        return None if known is None else (int(known[0]), int(known[1]))
    if left != right:
        raise SizeMismatchError(f"the calibration's cameras differ in size: left {_px(left)}, right {_px(right)}")
    return int(left[0]), int(left[1])


def _px(size: tuple[int, int]) -> str:
    return f"{int(size[0])} × {int(size[1])} px"


def size_problem(calibration: StereoCalibration, size: tuple[int, int] | None, what: str,
                 calibration_name: str = "the calibration") -> str | None:
    """One line naming both sizes when ``what`` (e.g. "pair 'w1'", "video 'dive'") of ``size`` (width,
    height in pixels; None: unknown) differs from the size ``calibration`` was made at; None when they
    agree or either is unknown."""
    made_at = calibration_size(calibration)
    if made_at is None or size is None:
        return None
    size = (int(size[0]), int(size[1]))
    if size == made_at:
        return None
    return (f"{what} is {_px(size)} but {calibration_name} was made at {_px(made_at)}: a calibration holds only "
            "for pictures of its own size (make or import one at this size)")


def check_size(calibration: StereoCalibration, size: tuple[int, int] | None, what: str,
               calibration_name: str = "the calibration") -> None:
    """Raise :class:`SizeMismatchError` with :func:`size_problem`'s line when the sizes differ."""
    problem = size_problem(calibration, size, what, calibration_name)
    if problem is not None:
        raise SizeMismatchError(problem)


def media_size(project: ProjectStore, label: str) -> tuple[int, int] | None:
    """(width, height) in pixels of a pair's images or a video's frames: as recorded when it was added,
    else read from the left image file's header; None when the pair has no pictures (observations only)
    or its size cannot be told without decoding."""
    pair = next((p for p in project.pairs() if p.label == label), None)
    if pair is not None and pair.width and pair.height:
        return int(pair.width), int(pair.height)
    if pair is not None and pair.left:
        try:
            path = project.image_path(pair.left)
            with open(path, "rb") as file:
                return declared_size(file.read(1 << 16))
        except (OSError, UsvipsError):
            return None
    video = next((v for v in project.videos() if v.label == label), None)
    if video is not None:
        return int(video.width), int(video.height)
    return None


def _kind(project: ProjectStore, label: str) -> str:
    return "video" if any(v.label == label for v in project.videos()) else "pair"


def _misfit(project: ProjectStore, calibration: StereoCalibration, label: str, calibration_name: str) -> str | None:
    """:func:`size_problem` for pair or video ``label`` (its kind looked up only when the sizes differ:
    the window asks for every frame of a video it shows)."""
    size, made_at = media_size(project, label), calibration_size(calibration)
    if size is None or made_at is None or tuple(int(v) for v in size) == made_at:
        return None
    return size_problem(calibration, size, f"{_kind(project, label)} {label!r}", calibration_name)


def check_for(project: ProjectStore, calibration: StereoCalibration, labels: Iterable[str],
              calibration_name: str = "the calibration") -> None:
    """Refuse (one line, the first misfit named) when any pair or video of ``labels`` has pictures of
    another size than ``calibration``'s."""
    for label in labels:
        problem = _misfit(project, calibration, label, calibration_name)
        if problem is not None:
            raise SizeMismatchError(problem)


def misfits(project: ProjectStore, calibration: StereoCalibration, labels: Iterable[str],
            calibration_name: str = "the calibration") -> list[str]:
    """One line per pair or video of ``labels`` whose pictures differ in size from ``calibration``'s."""
    lines = (_misfit(project, calibration, label, calibration_name) for label in labels)
    return [line for line in lines if line is not None]


def activate(project: ProjectStore, label: str, calibration_id: int) -> None:
    """Make stored calibration ``calibration_id`` the active one of pair or video ``label``, refused by
    name when their sizes differ (the one way the command line and the window make a calibration active)."""
    calibration = read_calibration(project, calibration_id)
    check_for(project, calibration, [label], f"calibration {calibration_id}")
    make_active(project, label, calibration_id)


def calibration_dict_size_check(project: ProjectStore, data: dict, labels: Iterable[str], source: str | Path) -> None:
    """Before storing a calibration (as a dict, e.g. being imported) active for ``labels``: refuse when
    any of them has pictures of another size."""
    check_for(project, calibration_from_dict(data, str(source)), labels, f"the calibration {Path(str(source)).name}")
