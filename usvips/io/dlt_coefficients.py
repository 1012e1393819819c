"""Stereo calibrations from other tools as 11 DLT coefficients per camera (StereoMorph, DLTdv, Argus, VidSync,
easyWand): read, checked line by line, and made a USVIPS in-air calibration.

The file: a table of numbers separated by commas, tabs or spaces — 11 rows with one column per camera (the
layout DLTdv and Argus write, ``*-dlt-coefs.csv``), or one row of 11 per camera. Blank lines and lines
starting with ``#`` are skipped, one header line of words is allowed at the top. A comment
``# rms_px: 0.43`` (or a row ``rms_px,0.43``) states the reprojection RMS the tool reported: it becomes the
calibration's sigma0 (origin ``stated``); a value the user gives is ``given``; without either it is an assumed
value, marked ``assumed`` (``statistics["sigma0_origin"]``, :attr:`StereoCalibration.sigma0_origin`, as an
OpenCV import's), which every figure made with it says.

Conventions. Coefficients L1…L11 map object points to pixels, u = (L1 X + L2 Y + L3 Z + L4) / (L9 X + L10 Y
+ L11 Z + 1) and v likewise with L5…L8. Their pixels are turned into USVIPS's (x right, y down, the origin at
the centre of the top-left pixel): ``origin="bottom-left"`` (DLTdv's and Argus's y up) flips y over the image
height, ``one_based`` (MATLAB's first pixel at 1) shifts by one. Object coordinates are scaled by ``unit`` to
metres. The 11-parameter DLT has no lens distortion; its skew (a sheared pixel grid) is not part of USVIPS's
interior: it is dropped and its effect stated per band of image rows in pixels (``skew_px`` in the
calibration's statistics; :func:`usvips.core.dlt.skew_effect`), exact for every point.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from usvips.core.camera import Camera
from usvips.core.dlt import DltCamera, camera_from_matrix, matrix_from_coefficients, skew_effect
from usvips.core.errors import DegenerateGeometryError, InputFileError, InvalidParameterError
from usvips.core.interior import Interior
from usvips.core.plain_numbers import plain_number
from usvips.core.stereo_calibration import ParameterEstimate, StereoCalibration
from usvips.io.opencv_calibration import ASSUMED_SIGMA0_PX
from usvips.io.text_lines import not_utf8, split_lines

UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
ORIGINS = ("top-left", "bottom-left")
_RMS = re.compile(r"^\s*#?\s*rms_px\s*[:,=\s]\s*(\S+)\s*$", re.IGNORECASE)
_SPLIT = re.compile(r"[,;\t ]+")


def read_coefficients(path: str | Path) -> tuple[np.ndarray, float | None]:
    """The coefficients (cameras, 11) of a DLT file and the reprojection RMS (pixels) it states, or None.
    Every problem names the file and the line."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as error:
        raise not_utf8(str(path), error.object, error.start, "file of DLT coefficients") from None
    rows: list[tuple[int, list[float]]] = []
    rms, header = None, None
    for number, line in enumerate(split_lines(text), start=1):
        stated = _RMS.match(line)
        if stated:
            try:
                rms = float(stated.group(1))
            except ValueError:
                rms = float("nan")
            if not (np.isfinite(rms) and rms > 0):
                raise InputFileError(f"{path} line {number}", f"rms_px must be a positive number, got "
                                     f"{stated.group(1)!r}")
            continue
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        if ";" in line and "," in line:  # 1,5;2,25: a spreadsheet's export with decimal commas
            raise InputFileError(f"{path} line {number}", "fields separated by semicolons with decimal commas: "
                                 "save the numbers with decimal points (and commas or tabs between them)")
        fields = [f.strip().strip('"') for f in _SPLIT.split(line.strip()) if f]
        values = []
        for field in fields:
            try:
                values.append(float(plain_number(field)))
            except ValueError:
                values.append(None)
        if any(v is None for v in values):
            if not rows and header is None and all(v is None for v in values):
                header = number
                continue  # one header line of words
            bad = next(f for f, v in zip(fields, values, strict=True) if v is None)
            raise InputFileError(f"{path} line {number}", f"{bad!r} is not a number")
        if not all(np.isfinite(values)):
            raise InputFileError(f"{path} line {number}", "holds a value that is not finite")
        if rows and len(values) != len(rows[0][1]):
            raise InputFileError(f"{path} line {number}", f"{len(values)} values where line {rows[0][0]} has "
                                 f"{len(rows[0][1])}")
        rows.append((number, values))
    if not rows:
        raise InputFileError(str(path), "holds no DLT coefficients")
    table = np.array([values for _, values in rows])
    if table.shape[0] == 11:
        cameras = table.T
    elif table.shape[1] == 11:
        cameras = table
    else:
        raise InputFileError(str(path), f"{table.shape[0]} rows of {table.shape[1]} values: a DLT has 11 "
                             "coefficients per camera (11 rows, one column per camera, or one row of 11 per camera)")
    return cameras, rms


def to_usvips_pixels(matrix: np.ndarray, origin: str, one_based: bool, height: int | None) -> np.ndarray:
    """The projection ``matrix`` of the tool's pixels as one of USVIPS's (x right, y down, 0 at the centre of
    the top-left pixel)."""
    if origin not in ORIGINS:
        raise InvalidParameterError("origin", f"must be one of {', '.join(ORIGINS)}, got {origin!r}")
    change = np.eye(3)
    shift = 1.0 if one_based else 0.0
    change[0, 2] = -shift
    if origin == "bottom-left":
        if not height:
            raise InvalidParameterError("image size", "an image origin at the bottom left needs the image height")
        change[1, 1], change[1, 2] = -1.0, height - 1.0 + shift
    else:
        change[1, 2] = -shift
    return change @ matrix


def calibration_from_dlt(path: str | Path, cameras: tuple[int, int] = (1, 2), origin: str = "top-left",
                         one_based: bool = False, size: tuple[int, int] | None = None, unit: str = "m",
                         sigma0_px: float | None = None) -> tuple[StereoCalibration, dict[str, DltCamera]]:
    """A USVIPS in-air stereo calibration (one station ``dlt``, the DLT's object frame) from the DLT file at
    ``path``: ``cameras`` are the 1-based numbers of the left and right camera in the file. Returns it and the
    decomposed cameras (their skew). sigma0 is ``sigma0_px`` when given, else the file's stated RMS, else
    :data:`usvips.io.opencv_calibration.ASSUMED_SIGMA0_PX` marked as assumed."""
    if unit not in UNITS:
        raise InvalidParameterError("unit", f"must be one of {', '.join(UNITS)}, got {unit!r}")
    if sigma0_px is not None and not (np.isfinite(sigma0_px) and sigma0_px > 0):
        raise InvalidParameterError("sigma0", f"must be > 0 pixels, got {sigma0_px}")
    coefficients, rms = read_coefficients(path)
    count = len(coefficients)
    if count < 2:
        raise InputFileError(str(path), "holds one camera's coefficients: a stereo calibration needs two")
    if len(set(cameras)) != 2 or not all(1 <= c <= count for c in cameras):
        raise InvalidParameterError("cameras", f"two different camera numbers from 1 to {count} (the file holds "
                                    f"{count}), got {cameras}")
    width, height = size if size else (None, None)
    scale = np.diag([1 / UNITS[unit]] * 3 + [1.0])  # metres → the file's unit
    decomposed = {}
    placed = []
    for side, number in zip(("left", "right"), cameras, strict=True):
        matrix = to_usvips_pixels(matrix_from_coefficients(coefficients[number - 1]), origin, one_based, height)
        try:
            camera = camera_from_matrix(matrix @ scale, f"camera {number}")
        except DegenerateGeometryError as error:
            raise InputFileError(str(path), str(error)) from None
        decomposed[side] = camera
        placed.append(Camera(Interior(f=camera.f, xp=camera.xp, yp=camera.yp, sy=camera.sy), camera.exterior,
                             width=width, height=height))
    if np.linalg.norm(placed[0].exterior.position - placed[1].exterior.position) == 0:
        raise InputFileError(str(path), "the two cameras share one centre, which is not a stereo rig")
    parameters = {}
    for suffix, camera in (("l", placed[0]), ("r", placed[1])):
        for name in ("f", "xp", "yp", "sy", "k1", "k2", "p1", "p2", "k3"):
            parameters[f"{name}_{suffix}"] = ParameterEstimate(float(getattr(camera.interior, name)), None, "fixed")
    if sigma0_px is not None:
        sigma0, sigma0_origin = float(sigma0_px), "given"
    elif rms is not None:
        sigma0, sigma0_origin = float(rms), "stated"
    else:
        sigma0, sigma0_origin = ASSUMED_SIGMA0_PX, "assumed"
    statistics = {"sigma0_origin": sigma0_origin,
                  "skew_px": {side: {"skew": c.skew, **skew_effect(c, height)} for side, c in decomposed.items()}}
    if sigma0_origin == "stated":
        statistics["sigma0_basis"] = "the reprojection RMS the DLT file states"
    source = {"dlt": str(path), "cameras": list(cameras), "origin": origin, "one_based": one_based, "unit": unit}
    calibration = StereoCalibration.from_cameras(placed[0], placed[1], "air", sigma0,
                                                 station="dlt", parameters=parameters, statistics=statistics,
                                                 source=source)
    return calibration, decomposed
