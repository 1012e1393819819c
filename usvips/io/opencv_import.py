"""Pinhole stereo calibrations from OpenCV (``cv2.FileStorage`` YAML/XML, or ``.npz``).

OpenCV's camera frame is x right, y down, z forward; ours is x right, y up, looking along −z (see
``core/interior.py``): M = diag(1, −1, −1)·R_cv. Distortion (k1, k2, p1, p2 on x-right/y-down
normalised coordinates) becomes K1 = k1, K2 = k2, P1 = p2, P2 = −p1; f = fx, sy = fx / fy, (xp, yp)
= (cx, cy). OpenCV's stereo extrinsics (R, T) map the left camera frame into the right one; the left
camera is placed at the origin of the object frame with its own axes (our rig frame). Higher-order
terms (k3, rational, thin prism, tilt) have no place in our model: non-zero ones are refused.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InputFileError
from usvips.core.interior import Interior
from usvips.core.rotation import angles_from_matrix
from usvips.core.stereo_calibration import StereoCalibration

FLIP = np.diag([1.0, -1.0, -1.0])
NAMES = {"K1": ("K1", "M1", "cameraMatrix1", "camera_matrix_left"),
         "D1": ("D1", "dist1", "distCoeffs1", "distortion_left"),
         "K2": ("K2", "M2", "cameraMatrix2", "camera_matrix_right"),
         "D2": ("D2", "dist2", "distCoeffs2", "distortion_right"),
         "R": ("R",), "T": ("T",)}


def interior_from_opencv(matrix: np.ndarray, distortion: np.ndarray, path: str, which: str) -> Interior:
    matrix = np.asarray(matrix, dtype=np.float64).reshape(3, 3)
    coefficients = np.asarray(distortion, dtype=np.float64).ravel()
    if coefficients.size < 4:
        coefficients = np.concatenate([coefficients, np.zeros(4 - coefficients.size)])
    if np.any(np.abs(coefficients[4:]) > 0):
        raise InputFileError(path, f"{which}: distortion terms beyond k1, k2, p1, p2 are not zero "
                             f"({coefficients[4:].tolist()}); USVIPS models K1, K2, P1, P2 only")
    if abs(matrix[0, 1]) > 1e-9 * abs(matrix[0, 0]):
        raise InputFileError(path, f"{which}: the camera matrix has skew {matrix[0, 1]:g}; USVIPS has none")
    k1, k2, p1, p2 = coefficients[:4]
    fx, fy = matrix[0, 0], matrix[1, 1]
    return Interior(f=fx, xp=matrix[0, 2], yp=matrix[1, 2], sy=fx / fy, k1=k1, k2=k2, p1=p2, p2=-p1)


def _read(path: Path) -> dict[str, np.ndarray]:
    if path.suffix == ".npz":
        try:
            with np.load(path) as data:
                return {k: np.asarray(data[k]) for k in data.files}
        except (OSError, ValueError) as error:
            raise InputFileError(str(path), f"not a readable .npz file: {error}") from None
    try:
        storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as error:
        detail = str(error).strip().splitlines()[-1][:200]
        raise InputFileError(str(path), f"not a readable OpenCV FileStorage file (YAML/XML): {detail}") from None
    if not storage.isOpened():
        raise InputFileError(str(path), "not an OpenCV FileStorage file (YAML/XML)")
    try:
        out = {}
        for names in NAMES.values():
            for name in names:
                node = storage.getNode(name)
                if not node.empty():
                    out[name] = node.mat()
        return out
    finally:
        storage.release()


def read_opencv_stereo(path: str | Path, size: tuple[int, int] | None = None,
                       sigma0_px: float = 0.5) -> StereoCalibration:
    """A pinhole stereo calibration (phase ``air``, no housing) in the rig frame."""
    path = Path(path)
    if not path.is_file():
        raise InputFileError(str(path), "no such file")
    data = _read(path)
    found = {}
    for key, names in NAMES.items():
        value = next((data[n] for n in names if n in data and data[n] is not None), None)
        if value is None:
            raise InputFileError(str(path), f"missing {key} (looked for {', '.join(names)})")
        found[key] = np.asarray(value, dtype=np.float64)
    left = interior_from_opencv(found["K1"], found["D1"], str(path), "left camera")
    right = interior_from_opencv(found["K2"], found["D2"], str(path), "right camera")
    rotation = found["R"].reshape(3, 3) if found["R"].size == 9 else cv2.Rodrigues(found["R"].reshape(3))[0]
    translation = found["T"].reshape(3)
    # x_right_cv = R x_left_cv + T; the right centre in the left camera frame is −Rᵀ T (OpenCV axes)
    centre_cv = -rotation.T @ translation
    m_right = FLIP @ rotation @ FLIP  # left (our axes) → right (our axes)
    width, height = size if size else (None, None)
    left_camera = Camera(left, Exterior(0, 0, 0), width=width, height=height)
    right_exterior = Exterior(*(FLIP @ centre_cv), *angles_from_matrix(m_right))
    right_camera = Camera(right, right_exterior, width=width, height=height)
    return StereoCalibration.from_cameras(left_camera, right_camera, "air", sigma0_px, station="rig",
                                          source={"opencv": str(path)})
