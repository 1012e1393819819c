"""OpenCV stereo calibrations: our cameras must project exactly as cv2.projectPoints does."""

import cv2
import numpy as np
import pytest

from usvips.core.errors import InputFileError
from usvips.io.opencv_import import read_opencv_stereo

K1 = np.array([[810.0, 0, 641.5], [0, 798.0, 478.25], [0, 0, 1]])
K2 = np.array([[805.0, 0, 630.0], [0, 801.0, 482.0], [0, 0, 1]])
D1 = np.array([-0.12, 0.03, 0.0012, -0.0008, 0.0])
D2 = np.array([-0.10, 0.02, -0.0005, 0.0009])
R = cv2.Rodrigues(np.array([0.01, -0.09, 0.004]))[0]
T = np.array([-0.39, 0.006, 0.012])


def _points():
    rng = np.random.default_rng(0)
    return np.column_stack([rng.uniform(-0.6, 0.8, 50), rng.uniform(-0.5, 0.5, 50), rng.uniform(1.5, 4.0, 50)])


def _check(calibration):
    points_cv = _points()                     # OpenCV's left camera frame (z forward)
    points_ours = points_cv * [1, -1, -1]     # the same points in our rig frame (left camera, y up, −z)
    rig = calibration.rig(frame="rig")
    left_cv, _ = cv2.projectPoints(points_cv, np.zeros(3), np.zeros(3), K1, D1)
    right_cv, _ = cv2.projectPoints(points_cv, cv2.Rodrigues(R)[0], T, K2, D2)
    np.testing.assert_allclose(rig.left.project(points_ours).pixels, left_cv.reshape(-1, 2), atol=1e-6)
    np.testing.assert_allclose(rig.right.project(points_ours).pixels, right_cv.reshape(-1, 2), atol=1e-6)


def test_yaml_and_npz_import_project_like_opencv(tmp_path):
    path = tmp_path / "stereo.yml"
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for name, value in (("M1", K1), ("D1", D1.reshape(1, -1)), ("M2", K2), ("D2", D2.reshape(1, -1)), ("R", R),
                        ("T", T.reshape(3, 1))):
        storage.write(name, value)
    storage.release()
    _check(read_opencv_stereo(path))
    np.savez(tmp_path / "stereo.npz", K1=K1, D1=D1, K2=K2, D2=D2, R=R, T=T)
    _check(read_opencv_stereo(tmp_path / "stereo.npz"))


def test_unsupported_terms_and_missing_fields_are_refused(tmp_path):
    np.savez(tmp_path / "k3.npz", K1=K1, D1=np.array([-0.1, 0.02, 0, 0, 0.05]), K2=K2, D2=D2, R=R, T=T)
    with pytest.raises(InputFileError, match="beyond k1, k2, p1, p2"):
        read_opencv_stereo(tmp_path / "k3.npz")
    np.savez(tmp_path / "partial.npz", K1=K1, D1=D1)
    with pytest.raises(InputFileError, match="missing K2"):
        read_opencv_stereo(tmp_path / "partial.npz")
    (tmp_path / "junk.yml").write_text("not: [a, calibration")
    with pytest.raises(InputFileError):
        read_opencv_stereo(tmp_path / "junk.yml")
