"""Stereo calibrations exchanged with OpenCV, both directions.

Read: ``cv2.FileStorage`` YAML/XML (one file, or OpenCV's stereo-sample pair ``intrinsics.yml`` (M1, D1,
M2, D2) + ``extrinsics.yml`` (R, T, R1, R2, P1, P2, Q), the layout VIAME reads, or each camera's own file
(:data:`SINGLE_CAMERA_NAMES`, left then right) + the one with R and T) and NumPy ``.npz``.
Write: one FileStorage file (YAML or XML by its extension) or that pair, for the in-air model.

Conventions. OpenCV's camera frame is x right, y down, z forward; ours is x right, y up, looking along −z
(``core/interior.py``): a point's coordinates differ by FLIP = diag(1, −1, −1). The camera matrix gives
f = fx, sy = fx / fy, (xp, yp) = (cx, cy) (both use pixel centres at integers). Distortion (k1, k2, p1,
p2, k3 on x-right/y-down normalised coordinates) becomes K1 = k1, K2 = k2, K3 = k3, P1 = p2, P2 = −p1.
OpenCV's stereo extrinsics (R, T) map the left camera frame into the right one, x_r = R·x_l + T; the
left camera is placed at the origin of our rig frame with its own axes, so the right camera's rotation
is M = FLIP·R·FLIP and its centre FLIP·(−Rᵀ·T). T is in the unit the board was measured in: metres by
default, ``unit`` says otherwise (metres in every USVIPS file).

OpenCV's rational (k4, k5, k6), thin-prism (s1…s4) and tilted-sensor (τx, τy) terms have no place in
our model: non-zero ones are refused by name; a camera matrix with skew is refused.

σ0. An OpenCV file holds no covariance, so the figures measured with an imported calibration carry the
pointing share of their sigma only (they say so). Its σ0 is taken from the residual the file states
(:data:`RESIDUAL_KEYS`): ``cv2.calibrateCamera`` and ``cv2.stereoCalibrate`` return the RMS of the 2-D
reprojection error (the length of the (x, y) error vector; OpenCV's calibration sample writes it as
``avg_reprojection_error``, and ``per_view_reprojection_errors`` per view), so σ0 per image coordinate is
RMS / √2 (per-view errors: their root mean square, / √2). A file that states no residual gets
:data:`ASSUMED_SIGMA0_PX`, marked ``assumed`` (``statistics["sigma0_origin"]``), which every figure made
with it says; a σ0 the user gives is marked ``given``.
"""

from __future__ import annotations

import math
import re
import zipfile
import zlib
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from usvips.core.calibration import planar
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InputFileError, InvalidParameterError, UsvipsError, concerning
from usvips.core.interior import Interior
from usvips.core.rotation import angles_from_matrix
from usvips.core.stereo_calibration import ParameterEstimate, StereoCalibration
from usvips.io.atomic import write_text_atomic
from usvips.io.file_errors import not_a_file

# OpenCV's camera axes ↔ ours, and our interior as OpenCV's camera matrix: the core's conversions (the
# planar calibration start uses them too)
FLIP = planar.FLIP

#: OpenCV's distortion vector, in its order (4, 5, 8, 12 or 14 entries).
DISTORTION_TERMS = ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4", "taux", "tauy")
DISTORTION_LENGTHS = (4, 5, 8, 12, 14)
#: Terms beyond the five we model, grouped by the OpenCV model they belong to.
UNSUPPORTED_TERMS = {"rational model": ("k4", "k5", "k6"), "thin-prism model": ("s1", "s2", "s3", "s4"),
                     "tilted-sensor model": ("taux", "tauy")}

#: Our key → the names other tools write it under (first one is what we write).
NAMES = {"K1": ("M1", "K1", "cameraMatrix1", "camera_matrix_left", "mtx_l", "mtxL"),
         "D1": ("D1", "dist1", "distCoeffs1", "distortion_left", "dist_l", "distL"),
         "K2": ("M2", "K2", "cameraMatrix2", "camera_matrix_right", "mtx_r", "mtxR"),
         "D2": ("D2", "dist2", "distCoeffs2", "distortion_right", "dist_r", "distR"),
         "R": ("R", "rotation"), "T": ("T", "translation")}
#: One camera's matrix and distortion in a file of its own (OpenCV's calibration sample writes
#: ``camera_matrix`` and ``distortion_coefficients``): the first such file given is the left camera, the
#: second the right one.
SINGLE_CAMERA_NAMES = {"K": ("camera_matrix", "cameraMatrix", "mtx", "K"),
                       "D": ("distortion_coefficients", "distCoeffs", "dist_coeffs", "dist", "D")}
#: distortion models that are Brown's (OpenCV's default terms, its rational ones), as ROS ``camera_info``
#: and Kalibr name them
BROWN_MODELS = ("plumb_bob", "rational_polynomial", "radtan")
#: string entries that name a file's camera or distortion model (OpenCV's fisheye model, Kalibr's
#: equidistant and omnidirectional ones are not Brown's: such a file is refused, never read as Brown's)
MODEL_KEYS = ("distortion_model", "camera_model")
#: camera models that are pinhole projections (Kalibr's ``camera_model``)
PINHOLE_MODELS = ("pinhole",)
#: Where files carry the image size: (width key, height key) pairs, or one key holding (width, height).
SIZE_PAIRS = (("image_width", "image_height"), ("imageWidth", "imageHeight"), ("width", "height"))
SIZE_KEYS = ("image_size", "imageSize", "size")
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
#: names under which calibration tools state a reprojection residual (pixels, OpenCV's 2-D RMS), the first
#: found is used: one overall RMS, or per-view errors (whose RMS is taken)
RESIDUAL_KEYS = ("rms", "RMS", "rms_error", "reprojection_error", "avg_reprojection_error", "avg_reprojErr",
                 "stereo_rms", "reprojection_rms", "rmsError")
PER_VIEW_KEYS = ("per_view_errors", "per_view_reprojection_errors", "perViewErrors", "reprojection_errors")
#: the σ0 (px, one coordinate) an import assumes when its file states no residual (marked ``assumed``)
ASSUMED_SIGMA0_PX = 0.5


def stated_residual(data: dict[str, object], where: str) -> tuple[float, str] | None:
    """σ0 (px, one image coordinate) from the residual a file states, with one line saying what it read;
    None when it states none. A stated residual that is not a finite number > 0 is refused by name."""
    for key in RESIDUAL_KEYS + PER_VIEW_KEYS:
        if key not in data:
            continue
        values = np.asarray(data[key], dtype=np.float64).ravel()
        if values.size == 0 or not np.all(np.isfinite(values)) or np.any(values < 0) or not np.any(values > 0):
            raise InputFileError(where, f"{key}: a reprojection residual must be finite numbers >= 0 (not all 0), "
                                        f"got {values.tolist()[:5]}")
        rms = float(np.sqrt(np.mean(values ** 2)))
        what = f"{key} {rms:.4g} px" if values.size == 1 else f"{key} of {values.size} views, RMS {rms:.4g} px"
        return rms / math.sqrt(2.0), f"{what} (2-D RMS; per coordinate / √2)"
    return None
#: Rotation matrices are accepted when RᵀR is within this of the identity (OpenCV writes 15-17 digits).
ROTATION_TOLERANCE = 1e-6


# --------------------------------------------------------------------------------- the conventions
def _refuse_non_finite(values: np.ndarray, path: str, what: str) -> None:
    """An :class:`InputFileError` naming the first value of ``what`` that is not a finite number (its
    position from 1 in the file's row-major order), if any."""
    flat = np.asarray(values, dtype=np.float64).ravel()
    bad = np.flatnonzero(~np.isfinite(flat))
    if bad.size:
        raise InputFileError(path, f"{what} holds {flat[bad[0]]} at position {bad[0] + 1} of {flat.size}: "
                             "every value must be a finite number")


def interior_from_opencv(matrix: np.ndarray, distortion: np.ndarray, path: str, which: str) -> Interior:
    """Camera matrix (3, 3) and distortion vector (4, 5, 8, 12 or 14 terms) → :class:`Interior`.

    ``path`` and ``which`` (the camera) name the source in errors. Raises :class:`InputFileError`."""
    matrix = np.asarray(matrix, dtype=np.float64)
    if matrix.size != 9:
        raise InputFileError(path, f"{which}: the camera matrix must be 3 × 3 finite numbers, got shape "
                             f"{matrix.shape}")
    _refuse_non_finite(matrix, path, f"{which}: the camera matrix")
    matrix = matrix.reshape(3, 3)
    coefficients = np.asarray(distortion, dtype=np.float64).ravel()
    _refuse_non_finite(coefficients, path, f"{which}: the distortion vector")
    if coefficients.size not in DISTORTION_LENGTHS:
        raise InputFileError(path, f"{which}: the distortion vector must hold 4, 5, 8, 12 or 14 finite numbers "
                             f"(OpenCV's k1, k2, p1, p2[, k3[, k4, k5, k6[, s1..s4[, taux, tauy]]]]), got "
                             f"{coefficients.size}")
    values = dict(zip(DISTORTION_TERMS, coefficients.tolist(), strict=False))
    for model, terms in UNSUPPORTED_TERMS.items():
        used = [f"{t}={values[t]:g}" for t in terms if values.get(t, 0.0) != 0.0]
        if used:
            raise InputFileError(path, f"{which}: OpenCV's {model} ({', '.join(used)}) is not supported; "
                                 "USVIPS models k1, k2, k3, p1, p2 (recalibrate without CALIB_RATIONAL_MODEL, "
                                 "CALIB_THIN_PRISM_MODEL, CALIB_TILTED_MODEL)")
    if abs(matrix[0, 1]) > 1e-9 * abs(matrix[0, 0]):
        raise InputFileError(path, f"{which}: the camera matrix has skew {matrix[0, 1]:g}; USVIPS has none")
    if np.any(np.abs(matrix[1:, 0]) > 0) or abs(matrix[2, 1]) > 0 or matrix[2, 2] != 1.0:
        raise InputFileError(path, f"{which}: not a camera matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]: "
                             f"{matrix.tolist()}")
    fx, fy = matrix[0, 0], matrix[1, 1]
    if fx <= 0 or fy <= 0:
        raise InputFileError(path, f"{which}: focal lengths must be > 0, got fx={fx:g}, fy={fy:g}")
    try:
        return Interior(f=fx, xp=matrix[0, 2], yp=matrix[1, 2], sy=fx / fy, k1=values["k1"], k2=values["k2"],
                        p1=values["p2"], p2=-values["p1"], k3=values.get("k3", 0.0))
    except UsvipsError as error:
        raise InputFileError(path, f"{which}: {error}") from None


def interior_to_opencv(interior: Interior) -> tuple[np.ndarray, np.ndarray]:
    """:class:`Interior` → OpenCV camera matrix (3, 3) and distortion (1, 5): k1, k2, p1, p2, k3."""
    matrix, distortion = planar.camera_matrix(interior)
    return matrix, distortion.reshape(1, 5)


def rotation_from_opencv(value: np.ndarray, path: str, which: str = "R") -> np.ndarray:
    """R as a 3 × 3 matrix or a Rodrigues vector → a proper rotation matrix; anything else is refused."""
    value = np.asarray(value, dtype=np.float64)
    if not np.all(np.isfinite(value)):
        raise InputFileError(path, f"{which}: R holds a value that is not a finite number")
    if value.size == 3:
        return cv2.Rodrigues(value.reshape(3, 1))[0]
    if value.size != 9:
        raise InputFileError(path, f"{which}: R must be a 3 × 3 matrix or a Rodrigues vector of 3, got "
                             f"{value.size} numbers")
    rotation = value.reshape(3, 3)
    off = float(np.max(np.abs(rotation.T @ rotation - np.eye(3))))
    det = float(np.linalg.det(rotation))
    if off > ROTATION_TOLERANCE or det < 0:
        raise InputFileError(path, f"{which}: R is not a rotation (RᵀR differs from the identity by {off:.3g}, "
                             f"det R = {det:.6g}; a rotation has RᵀR = I and det R = +1)")
    return rotation


def stereo_from_opencv(arrays: dict[str, np.ndarray], size: tuple[int, int] | None, where: str,
                       unit: str = "m", sigma0_px: float = ASSUMED_SIGMA0_PX, source: dict | None = None,
                       sigma0_origin: str = "assumed", sigma0_basis: str = "") -> StereoCalibration:
    """K1, D1, K2, D2, R, T (OpenCV's stereo calibration) → a pinhole StereoCalibration in the rig frame
    (phase ``air``, no housing, one station ``rig``). ``unit`` is T's unit (m, cm, mm); ``sigma0_origin``
    (``stated``, ``given`` or ``assumed``) and ``sigma0_basis`` (what it rests on) go to its statistics."""
    path = where
    if unit not in UNITS:
        raise InvalidParameterError("unit", f"must be one of {', '.join(UNITS)}, got {unit!r}", label="unit of T")
    left = interior_from_opencv(arrays["K1"], arrays["D1"], path, "left camera (M1, D1)")
    right = interior_from_opencv(arrays["K2"], arrays["D2"], path, "right camera (M2, D2)")
    rotation = rotation_from_opencv(arrays["R"], path)
    translation = np.asarray(arrays["T"], dtype=np.float64).ravel()
    _refuse_non_finite(translation, path, "T")
    if translation.size != 3:
        raise InputFileError(path, f"T must be 3 finite numbers, got {translation.size}")
    translation = translation * UNITS[unit]
    if np.linalg.norm(translation) == 0:
        raise InputFileError(path, "T is zero: the two cameras share one centre, which is not a stereo rig")
    if np.linalg.norm(translation) < MIN_BASELINE_M:  # (any unit: a micrometre is no rig's baseline)
        raise InputFileError(path, f"T puts the cameras {np.linalg.norm(translation):.3g} m apart: they share "
                             "one centre for every purpose, which is not a stereo rig")
    centre_cv = -rotation.T @ translation  # the right centre in the left camera frame (OpenCV axes)
    m_right = FLIP @ rotation @ FLIP      # left frame (our axes) → right image frame (our axes)
    width, height = size if size else (None, None)
    left_camera = Camera(left, Exterior(0, 0, 0), width=width, height=height)
    right_camera = Camera(right, Exterior(*(FLIP @ centre_cv), *angles_from_matrix(m_right)),
                          width=width, height=height)
    parameters = {}
    for side, interior in (("l", left), ("r", right)):
        for name in ("f", "xp", "yp", "sy", "k1", "k2", "p1", "p2", "k3"):
            parameters[f"{name}_{side}"] = ParameterEstimate(float(getattr(interior, name)), None, "fixed")
    statistics = {"sigma0_origin": sigma0_origin}
    if sigma0_basis:
        statistics["sigma0_basis"] = sigma0_basis
    return StereoCalibration.from_cameras(left_camera, right_camera, "air", sigma0_px, station="rig",
                                          parameters=parameters, statistics=statistics,
                                          source=dict(source or {"opencv": path}))


def opencv_from_stereo(calibration: StereoCalibration) -> tuple[dict[str, np.ndarray], list[str]]:
    """A StereoCalibration → OpenCV's stereo arrays (M1, D1, M2, D2, R, T in metres; with the image size,
    also R1, R2, P1, P2, Q from ``cv2.stereoRectify``) and one line for each thing OpenCV cannot hold."""
    rig = calibration.rig(frame="rig")
    m1, d1 = interior_to_opencv(rig.left.interior)
    m2, d2 = interior_to_opencv(rig.right.interior)
    m_right = rig.right.exterior.rotation
    rotation = FLIP @ m_right @ FLIP
    translation = -(FLIP @ m_right @ rig.right.exterior.position)
    out = {"M1": m1, "D1": d1, "M2": m2, "D2": d2, "R": rotation, "T": translation.reshape(3, 1)}
    left_out = []
    kind = calibration.left.housing.kind
    if kind != "air":
        housing = ", ".join(f"{k}={v:.6g}" for k, v in calibration.left.housing.parameters().items())
        left_out.append(f"the {kind} housing is left out (OpenCV has no refraction; left camera: {housing}): "
                        "the file is the in-air model, its pixels do not match underwater images")
    if len(calibration.stations) > 1 or calibration.stations != ("rig",):
        left_out.append(f"the pose{'s' if len(calibration.stations) > 1 else ''} of station(s) "
                        f"{', '.join(calibration.stations)} in the object frame "
                        f"{'are' if len(calibration.stations) > 1 else 'is'} left out: "
                        "OpenCV's stereo file holds the rig (left camera at the origin) only")
    if calibration.covariance is not None or any(p.sigma for p in calibration.parameters.values()):
        left_out.append("the parameters' sigmas and covariance are left out (OpenCV's file has no place for them)")
    if calibration.sigma0_origin != "assumed" and calibration.sigma0_px > 0:  # (an assumed one is no residual)
        out["rms"] = float(calibration.sigma0_px * math.sqrt(2.0))  # OpenCV's 2-D RMS: read back as this σ0
    sizes = {(c.width, c.height) for c in (calibration.left, calibration.right)}
    if len(sizes) == 1 and None not in next(iter(sizes)):
        width, height = next(iter(sizes))
        out["image_width"], out["image_height"] = int(width), int(height)
        r1, r2, p1, p2, q, _, _ = cv2.stereoRectify(m1, d1, m2, d2, (int(width), int(height)), rotation,
                                                    translation.reshape(3, 1))
        out.update({"R1": r1, "R2": r2, "P1": p1, "P2": p2, "Q": q})
    elif len(sizes) > 1:
        left_out.append(f"the cameras' image sizes differ ({sorted(sizes)}): OpenCV's stereo file holds one, "
                        "none is written and R1, R2, P1, P2, Q are left out")
    else:
        left_out.append("the image size is unknown: R1, R2, P1, P2, Q (rectification) are left out")
    return out, left_out


# --------------------------------------------------------------------------------- files
def _node_value(node) -> np.ndarray | float | None:
    if node.empty():
        return None
    if node.isInt() or node.isReal():
        return float(node.real())
    if node.isSeq():
        items = [node.at(i) for i in range(node.size())]
        if all(item.isInt() or item.isReal() for item in items):
            return np.array([item.real() for item in items], dtype=np.float64)
        return None
    if node.isMap():
        _check_matrix_node(node)
        if node.getNode("dt").empty() and not node.getNode("data").empty():  # ROS camera_info: rows, cols, data
            data, shape = node.getNode("data"), _declared_shape(node)
            return np.array([data.at(i).real() for i in range(data.size())], dtype=np.float64).reshape(shape)
        value = node.mat()
        return None if value is None else np.asarray(value)
    return None


def _check_matrix_node(node) -> None:
    """Refuse a damaged matrix before OpenCV reads it: a missing rows/cols, or data that do not match them,
    can corrupt OpenCV's heap and end the process instead of raising (seen with OpenCV 5.0)."""
    data = node.getNode("data")
    shape = _declared_shape(node)
    if shape is None:
        if data.empty():
            return  # a map that is not a matrix: OpenCV reads it as no matrix
        raise ValueError("a matrix without its rows and cols (or sizes)")
    if any(not 0 <= side <= _MAX_MATRIX_SIDE for side in shape):
        raise ValueError(f"a matrix of {' × '.join(map(str, shape))} is not a calibration matrix")
    channels = re.match(r"\d*", node.getNode("dt").string() or "")
    expected = math.prod(shape) * int(channels.group() or 1)
    count = data.size() if data.isSeq() else (1 if data.isInt() or data.isReal() else 0)
    if count != expected:
        raise ValueError(f"its data hold {count} numbers, its size says {expected}")
    if data.isSeq() and not all(data.at(i).isInt() or data.at(i).isReal() for i in range(count)):
        raise ValueError("its data hold something that is not a number")
    kind = (node.getNode("dt").string() or "")[len(channels.group()):]
    if kind in _INTEGER_TYPES:  # OpenCV would round the data to the declared type, silently
        values = [data.at(i).real() for i in range(count)] if data.isSeq() else [data.real()]
        fraction = next((v for v in values if not float(v).is_integer()), None)
        if fraction is not None:
            raise ValueError(f"it declares whole numbers (dt: {kind}) but holds {fraction:g}, which OpenCV would "
                             "round: write dt: d")


def _declared_shape(node) -> list[int] | None:
    """The shape a matrix node declares: rows and cols (opencv-matrix) or sizes (opencv-nd-matrix)."""
    rows, cols = node.getNode("rows"), node.getNode("cols")
    if rows.isInt() and cols.isInt():
        return [int(rows.real()), int(cols.real())]
    sizes = node.getNode("sizes")
    if sizes.isSeq() and sizes.size() and all(sizes.at(i).isInt() for i in range(sizes.size())):
        return [int(sizes.at(i).real()) for i in range(sizes.size())]
    return None


#: the entries an import reads: the cameras' matrices and distortions, R and T, the image size, the stated
#: residual, ROS's rectification and projection (any other entry is another tool's and is not read)
_USED_KEYS = frozenset({*(n for names in NAMES.values() for n in names),
                        *(n for names in SINGLE_CAMERA_NAMES.values() for n in names),
                        *(k for pair in SIZE_PAIRS for k in pair), *SIZE_KEYS, *RESIDUAL_KEYS, *PER_VIEW_KEYS,
                        "rectification_matrix", "projection_matrix"})


#: OpenCV FileStorage element types of whole numbers (``dt``): they round what the data hold
_INTEGER_TYPES = frozenset("ucwsi")


#: the largest matrix side a calibration file holds (a 4 × 4 Q, a 1 × 14 distortion vector, …) with
#: room to spare; a larger rows/cols is a damaged file, refused before OpenCV allocates it
_MAX_MATRIX_SIDE = 1000


#: the most bytes one array of an .npz file may unpack to (a calibration's arrays take a few hundred)
_MAX_NPZ_ARRAY_BYTES = 16 << 20


def _read_npz(path: Path) -> dict[str, object]:
    """Every array of a NumPy .npz file, numbers only: a damaged archive (bad zip, bad CRC, a cut-short
    member, a corrupt header), an array of text, objects or complex numbers, or one that would unpack to
    more than :data:`_MAX_NPZ_ARRAY_BYTES` is an :class:`InputFileError` naming the file (and the array)."""
    out = {}
    with open(path, "rb") as stream:
        magic = stream.read(6)
    if not magic.startswith(b"PK"):
        saved = " (a single array saved by np.save: save the arrays by name with np.savez)" \
            if magic == b"\x93NUMPY" else ""
        raise InputFileError(str(path), f"not a .npz archive{saved}")
    try:
        with np.load(path, allow_pickle=False) as data:
            for key in data.files:
                info = data.zip.getinfo(f"{key}.npy")
                if info.file_size > _MAX_NPZ_ARRAY_BYTES:
                    raise InputFileError(str(path), f"array {key!r} unpacks to {info.file_size} bytes; a "
                                         "calibration's arrays are small (a damaged or a different file?)")
                value = np.asarray(data[key])
                if value.dtype.kind not in "biuf":
                    raise InputFileError(str(path), f"array {key!r} holds {value.dtype} values, not real numbers")
                out[key] = value
    except InputFileError:
        raise
    except (OSError, ValueError, EOFError, KeyError, RuntimeError, zipfile.BadZipFile, zlib.error) as error:
        detail = " ".join(str(error).split())[:200] or type(error).__name__
        raise InputFileError(str(path), f"not a readable .npz file (damaged?): {detail}") from None
    return out


def _read_file(path: Path) -> dict[str, object]:
    """Every top-level numeric entry of one file (arrays and numbers), by its name in the file."""
    if not path.is_file():
        raise not_a_file(path)
    if path.suffix.lower() == ".npz":
        return _read_npz(path)
    with open(path, "rb") as stream:
        head = stream.read(4)
    if not head:
        raise InputFileError(str(path), "the file is empty")
    if head.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise InputFileError(str(path), "is UTF-16 text, not UTF-8: save it as UTF-8 (OpenCV reads UTF-8 YAML/XML)")
    source, flags = str(path), cv2.FILE_STORAGE_READ
    if head.startswith(b"\xef\xbb\xbf"):  # a byte-order mark (Windows Notepad), which OpenCV does not skip
        source = path.read_bytes()[3:].decode("utf-8", errors="replace")
        flags |= cv2.FILE_STORAGE_MEMORY | (cv2.FILE_STORAGE_FORMAT_XML if path.suffix.lower() == ".xml"
                                             else cv2.FILE_STORAGE_FORMAT_YAML)
    try:
        storage = cv2.FileStorage(source, flags)
    except (cv2.error, SystemError) as error:
        cause = error.__cause__ if isinstance(error, SystemError) and error.__cause__ is not None else error
        lines = str(cause).strip().splitlines() or ["the file is damaged or cut short"]
        detail = lines[-1][:200] if "exception set" not in lines[-1] else "the file is damaged or cut short"
        raise InputFileError(str(path), f"not a readable OpenCV FileStorage file (YAML/XML): {detail}") from None
    if not storage.isOpened():
        raise InputFileError(str(path), "not an OpenCV FileStorage file (YAML/XML)")
    try:
        root = storage.root()
        if not root.isMap():
            raise InputFileError(str(path), "an OpenCV FileStorage file holds named entries at its top level; "
                                            "this one does not")
        out = {}
        try:
            keys = root.keys()
        except UnicodeDecodeError:  # a name with bytes that are not UTF-8 (OpenCV hands them over undecoded)
            raise InputFileError(str(path), "an entry's name is not UTF-8 text: the file is damaged or not an "
                                            "OpenCV calibration") from None
        for key in keys:
            if key not in _USED_KEYS:
                continue  # another tool's entry (a board, a header, image points): not read, whatever it holds
            try:
                value = _node_value(storage.getNode(key))
            except ValueError as error:
                raise InputFileError(str(path), f"entry {key!r}: {error}") from None
            except cv2.error:
                raise InputFileError(str(path), f"entry {key!r} is not a readable matrix: its rows, cols and data do "
                                                "not agree, or its data hold something that is not a number") from None
            if value is not None:
                out[key] = value
        for key in MODEL_KEYS:
            model = storage.getNode(key)
            if model.isString():
                out[key] = model.string()
        fisheye = storage.getNode("fisheye_model")  # OpenCV's calibration sample (camera_calibration.cpp)
        if fisheye.isInt() or fisheye.isReal():
            out["fisheye_model"] = float(fisheye.real())
        return out
    finally:
        storage.release()


def _size_of(data: dict[str, object], path: str) -> tuple[int, int] | None:
    """The image size (width, height) the file states; two statements of it that differ are refused."""
    stated = []
    for width_key, height_key in SIZE_PAIRS:
        if width_key in data and height_key in data:
            stated.append((f"{width_key}/{height_key}", (data[width_key], data[height_key])))
    for key in SIZE_KEYS:
        if key in data:
            value = np.asarray(data[key], dtype=np.float64).ravel()
            if value.size != 2:
                raise InputFileError(path, f"{key} must hold (width, height), got {value.size} numbers")
            stated.append((key, tuple(value)))
    sizes = []
    for name, found in stated:
        width, height = (float(np.asarray(v).ravel()[0]) for v in found)
        if not (width.is_integer() and height.is_integer() and 0 < width <= MAX_IMAGE_SIDE
                and 0 < height <= MAX_IMAGE_SIDE):
            raise InputFileError(path, f"{name}: image size {width:g} × {height:g} is not a whole number of pixels "
                                 f"from 1 to {MAX_IMAGE_SIDE}")
        sizes.append((name, (int(width), int(height))))
    if not sizes:
        return None
    for name, size in sizes[1:]:
        if size != sizes[0][1]:
            raise InputFileError(path, f"the file states two image sizes: {sizes[0][0]} {sizes[0][1][0]}x"
                                 f"{sizes[0][1][1]}, {name} {size[0]}x{size[1]}")
    return sizes[0][1]


def read_opencv_stereo(paths: str | Path | Sequence[str | Path], size: tuple[int, int] | None = None,
                       unit: str = "m", sigma0_px: float | None = None) -> StereoCalibration:
    """A pinhole stereo calibration (phase ``air``, no housing) from one file or the intrinsics +
    extrinsics pair. ``size`` (width, height in pixels) where the files do not carry it; a size that
    disagrees with a file's, or two files that disagree, is refused. ``sigma0_px``: σ0 given by the user
    (marked ``given``); None: the residual the files state (``stated``, :func:`stated_residual`), else
    :data:`ASSUMED_SIGMA0_PX` marked ``assumed``."""
    if sigma0_px is not None and not (math.isfinite(sigma0_px) and sigma0_px > 0):
        raise InvalidParameterError("sigma0", f"must be a finite number of pixels > 0, got {sigma0_px!r}")
    paths = [Path(paths)] if isinstance(paths, str | Path) else [Path(p) for p in paths]
    if not paths:
        raise InvalidParameterError("FILE", "give one calibration file or the intrinsics + extrinsics pair")
    merged: dict[str, np.ndarray] = {}
    origin: dict[str, Path] = {}
    file_size, size_origin = None, None
    stereo_stated, camera_stated = None, []
    singles: list[dict[str, object]] = []
    for path in paths:
        _refuse_usvips_file(path)
        data = _read_file(path)
        _refuse_other_models(data, path)
        single = _single_camera(data, path)
        if single is not None:
            if len(singles) == 2:
                raise InputFileError(str(path), "a third file of one camera's calibration: give the left camera's "
                                     "file, then the right camera's, then the one with R and T")
            singles.append(single)
            data = {**data, **{f"{key}{len(singles)}": single[key] for key in ("K", "D")}}
        found = _stated(data, path)
        if found is not None and single is not None:
            camera_stated.append(found)
        elif found is not None and stereo_stated is None:
            stereo_stated = found
        this_size = _size_of(data, str(path))
        if this_size is not None:
            if file_size is not None and this_size != file_size:
                raise InputFileError(str(path), f"mismatched image sizes: {this_size[0]}x{this_size[1]} here, "
                                     f"{file_size[0]}x{file_size[1]} in {size_origin}")
            file_size, size_origin = this_size, path
        for key, names in NAMES.items():
            given = [n for n in names if n in data]
            if not given:
                continue
            name, value = given[0], np.asarray(data[given[0]], dtype=np.float64)
            for other in given[1:]:
                again = np.asarray(data[other], dtype=np.float64)
                if again.shape != value.shape or not np.array_equal(again, value):
                    raise InputFileError(str(path), f"{name} and {other} both give {key} and differ: keep one")
            if key in merged and (merged[key].shape != value.shape or not np.array_equal(merged[key], value)):
                raise InputFileError(str(path), f"{name} differs from the one in {origin[key]}")
            merged[key], origin[key] = value, path
    where = " + ".join(str(p) for p in paths)
    cameras = len(singles)
    if cameras == 2 and "R" not in merged and "T" not in merged and all("projection" in c for c in singles):
        merged.update(_relative_from_rectification(*singles, where))  # a ROS camera_info pair
    missing = [key for key in NAMES if key not in merged]
    if missing:
        looked = "; ".join(f"{key}: {', '.join(NAMES[key])}" for key in missing)
        hint = " (OpenCV's stereo sample writes R and T to extrinsics.yml: give both files)" \
            if {"R", "T"} & set(missing) and len(paths) == 1 else ""
        if cameras == 1 and {"K2", "D2"} & set(missing):
            hint += " (one camera's own file was given: give the right camera's file after the left one's)"
        raise InputFileError(where, f"missing {', '.join(missing)} (looked for {looked}){hint}")
    if size is not None and file_size is not None and tuple(size) != file_size:
        raise concerning(InputFileError(str(size_origin), f"mismatched image sizes: the file says {file_size[0]}x"
                                        f"{file_size[1]}, the given image size is {size[0]}x{size[1]}"), "image_size")
    source = {"opencv": [str(p) for p in paths], "unit": unit}
    if sigma0_px is not None:
        sigma0, origin, basis = float(sigma0_px), "given", "given at import"
    elif (stated := stereo_stated or _combined(camera_stated)) is not None:
        sigma0, origin, basis = stated[0], "stated", stated[1]
    else:
        sigma0, origin, basis = ASSUMED_SIGMA0_PX, "assumed", "assumed: the file states no reprojection residual"
    return stereo_from_opencv(merged, tuple(size) if size else file_size, where, unit, sigma0, source, origin, basis)


def sigma0_statement(calibration: StereoCalibration) -> str:
    """What an imported calibration's sigma0 rests on, and that its figures' sigmas hold pointing only."""
    basis = calibration.statistics.get("sigma0_basis", "")
    text = {"stated": f"sigma0 {calibration.sigma0_px:.3g} px from the file ({basis})",
            "given": f"sigma0 {calibration.sigma0_px:.3g} px (given)",
            "assumed": f"sigma0 {calibration.sigma0_px:.3g} px ASSUMED: the file states no reprojection residual; "
                       "every figure made with this calibration says so"}.get(calibration.sigma0_origin,
                                                                             f"sigma0 {calibration.sigma0_px:.3g} px")
    return text + "; no parameter covariance: the figures' sigmas hold the pointing share only"


def _refuse_usvips_file(path: Path) -> None:
    """A USVIPS calibration given to the OpenCV import is named as such (OpenCV would read its JSON and
    find no camera matrix)."""
    try:
        with open(path, "rb") as stream:
            head = stream.read(4096)
    except OSError:
        return  # named where it is read
    if b'"usvips-calibration"' in head:
        raise InputFileError(str(path), "is already a USVIPS calibration: use it as it is (a project imports it as "
                             "a calibration)")


def _refuse_other_models(data: dict[str, object], path: Path) -> None:
    """A file that says its camera or distortion model is not a pinhole with Brown's distortion (OpenCV's
    fisheye model, Kalibr's equidistant or omnidirectional ones) is refused by name: its four distortion
    numbers would be read as Brown's k1, k2, p1, p2 and every ray would be wrong, silently."""
    if data.get("fisheye_model"):
        raise InputFileError(str(path), "a fisheye calibration (fisheye_model: 1, OpenCV's cv2.fisheye model): "
                             "USVIPS models Brown's radial and tangential distortion; calibrate with the "
                             "standard model (or in USVIPS)")
    for key in MODEL_KEYS:
        model = data.get(key)
        known = BROWN_MODELS if key == "distortion_model" else PINHOLE_MODELS
        if isinstance(model, str) and model.strip().lower() not in known:
            raise InputFileError(str(path), f"{key} {model!r} is not supported: USVIPS models a pinhole camera "
                                 f"with Brown's radial and tangential distortion ({' or '.join(known)})")


def _single_camera(data: dict[str, object], path: Path) -> dict[str, object] | None:
    """``{"K": matrix, "D": distortion}`` of a file that holds one camera (:data:`SINGLE_CAMERA_NAMES`) and no
    stereo camera keys, with ``"rectification"`` and ``"projection"`` when it has ROS's (a ``camera_info``
    file); None for any other file. A camera matrix without its distortion is refused by name (another
    model than Brown's: :func:`_refuse_other_models`)."""
    if any(name in data for key in ("K1", "D1", "K2", "D2") for name in NAMES[key]):
        return None
    found = {key: next((data[n] for n in names if n in data), None) for key, names in SINGLE_CAMERA_NAMES.items()}
    if found["K"] is None:
        return None
    if found["D"] is None:
        raise InputFileError(str(path), "a camera matrix without its distortion (looked for "
                             f"{', '.join(SINGLE_CAMERA_NAMES['D'])})")
    if "rectification_matrix" in data and "projection_matrix" in data:
        found["rectification"], found["projection"] = data["rectification_matrix"], data["projection_matrix"]
    return found


def _relative_from_rectification(left: dict[str, object], right: dict[str, object], where: str
                                 ) -> dict[str, np.ndarray]:
    """R and T (x_r = R·x_l + T, the calibration's unit) from two ROS ``camera_info`` files: each camera's
    rectification rotation R_i (camera → rectified frame) and rectified projection P_i = [K' | K'·t_i]. The
    rectified frames differ by t = t_r − t_l only, so R = R_rᵀ·R_l and T = R_rᵀ·t."""
    rotations, offsets = [], []
    for camera, which in ((left, "left"), (right, "right")):
        rotation = np.asarray(camera["rectification"], dtype=np.float64)
        projection = np.asarray(camera["projection"], dtype=np.float64)
        if rotation.shape != (3, 3) or projection.shape != (3, 4):
            raise InputFileError(where, f"the {which} camera's rectification_matrix must be 3 × 3 and its "
                                 f"projection_matrix 3 × 4, got {rotation.shape} and {projection.shape}")
        _refuse_non_finite(projection, where, f"the {which} camera's projection_matrix")
        rotations.append(rotation_from_opencv(rotation, where, f"the {which} camera's rectification_matrix"))
        inner = projection[:, :3]
        if abs(np.linalg.det(inner)) < 1e-12:
            raise InputFileError(where, f"the {which} camera's projection_matrix has no inverse: not a camera's")
        offsets.append(np.linalg.solve(inner, projection[:, 3]))
    if np.any(offsets[0] != 0.0) and not np.any(offsets[1] != 0.0):  # ROS: Tx = Ty = 0 for the first camera
        raise InputFileError(where, "the first camera_info file is the right camera's (its projection_matrix has "
                             "Tx or Ty ≠ 0, the second's none): give the left camera's file first")
    rotation = rotations[1].T @ rotations[0]
    return {"R": rotation, "T": (rotations[1].T @ (offsets[1] - offsets[0])).reshape(3, 1)}


def _combined(stated: list[tuple[float, str]]) -> tuple[float, str] | None:
    """σ0 of the two cameras' own calibrations: the root mean square of their σ0s, with what each rests on."""
    if not stated:
        return None
    sigma0 = math.sqrt(sum(s ** 2 for s, _ in stated) / len(stated))
    return sigma0, "; ".join(text for _, text in stated) + (" (their RMS)" if len(stated) > 1 else "")


def _stated(data: dict[str, object], path: Path) -> tuple[float, str] | None:
    found = stated_residual(data, str(path))
    return None if found is None else (found[0], f"{found[1]} in {path.name}")


def _storage_text(path: Path, entries: dict[str, object], comment: str) -> str:
    suffix = path.suffix.lower()
    if suffix not in (".yml", ".yaml", ".xml", ".json"):
        raise InvalidParameterError("out", f"{path}: the extension must be .yml, .yaml, .xml or .json "
                                    "(OpenCV FileStorage chooses the format by it)", label="output")
    storage = cv2.FileStorage(suffix, cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY)
    if suffix != ".json":
        storage.writeComment(comment)
    for key, value in entries.items():
        storage.write(key, value)
    return storage.releaseAndGetString()


def opencv_targets(path: str | Path) -> list[Path]:
    """The files :func:`write_opencv_stereo` writes for ``path``: the file itself, or in a folder the
    stereo sample's ``intrinsics.yml`` and ``extrinsics.yml``."""
    path = Path(path)
    return [path / "intrinsics.yml", path / "extrinsics.yml"] if path.is_dir() else [path]


def write_opencv_stereo(calibration: StereoCalibration, path: str | Path) -> list[str]:
    """Write OpenCV's stereo file (YAML, XML or JSON by the extension); a folder gets the stereo sample's
    pair ``intrinsics.yml`` (M1, D1, M2, D2) + ``extrinsics.yml`` (R, T, R1, R2, P1, P2, Q). Each file is
    written atomically. Returns one line per thing the file cannot hold (see :func:`opencv_from_stereo`)."""
    path = Path(path)
    arrays, left_out = opencv_from_stereo(calibration)
    comment = "written by USVIPS from a calibration; T in metres; USVIPS's in-air model of each camera"
    if path.is_dir():
        intrinsics = {k: arrays[k] for k in ("M1", "D1", "M2", "D2", "image_width", "image_height", "rms")
                      if k in arrays}
        extrinsics = {k: v for k, v in arrays.items() if k not in intrinsics or k.startswith("image_")}
        inner, outer = opencv_targets(path)
        texts = [(inner, _storage_text(inner, intrinsics, comment)), (outer, _storage_text(outer, extrinsics, comment))]
    else:
        texts = [(path, _storage_text(path, arrays, comment))]
    for target, text in texts:
        write_text_atomic(target, text)
    return left_out


#: the shortest baseline (m) an import takes: below it every ray pair meets at the cameras
MIN_BASELINE_M = 1e-6
#: baselines (m) of the stereo rigs the field uses, diver-held to ROV frames, with a wide margin
PLAUSIBLE_BASELINE_M = (0.01, 5.0)
#: the unit suggested first is the one that gives the baseline nearest this (m)
TYPICAL_BASELINE_M = 0.3


def baseline_doubt(calibration: StereoCalibration, unit: str) -> str | None:
    """A warning when the imported baseline is no stereo rig's (OpenCV's T is in the calibration board's
    unit, which the file does not record): the unit that would make it plausible, or None."""
    baseline = float(np.linalg.norm(calibration.relative.base))
    low, high = PLAUSIBLE_BASELINE_M
    if low <= baseline <= high:
        return None
    scale = UNITS[unit]
    fits = sorted((name for name, factor in UNITS.items() if name != unit and low <= baseline / scale * factor <= high),
                  key=lambda name: abs(np.log(baseline / scale * UNITS[name] / TYPICAL_BASELINE_M)))
    hint = f": is T in {' or '.join(fits)}?" if fits else ""
    return (f"the baseline is {baseline:.4g} m, outside the {low:g}–{high:g} m of stereo rigs, reading T in "
            f"{unit}{hint}")


#: the largest image side (pixels) taken from the command line: well above any camera's
MAX_IMAGE_SIDE = 65536


def parse_image_size(text: str, parameter: str = "image_size") -> tuple[int, int]:
    """``WxH`` (pixels) → (width, height); a malformed text is one error naming ``parameter``."""
    width, sep, height = text.lower().partition("x")
    try:
        size = int(width), int(height)
    except ValueError:
        size = None
    if not sep or size is None or min(size) <= 0:
        raise InvalidParameterError(parameter, f"expected WIDTHxHEIGHT in whole pixels > 0, got {text!r}")
    if max(size) > MAX_IMAGE_SIDE:
        raise InvalidParameterError(parameter, f"{size[0]}x{size[1]}: a side over {MAX_IMAGE_SIDE} pixels is no "
                                    "camera's image")
    return size
