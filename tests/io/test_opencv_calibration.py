"""OpenCV stereo calibrations both ways: our cameras must project exactly as cv2.projectPoints does with
what cv2.stereoCalibrate wrote, and OpenCV must project exactly as we do with what we write."""

import cv2
import numpy as np
import pytest

from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InputFileError, InvalidParameterError
from usvips.core.housing import FlatPortHousing
from usvips.core.interior import Interior
from usvips.core.stereo_calibration import StereoCalibration
from usvips.io.calibration_file import load_calibration, save_calibration
from usvips.io.opencv_calibration import read_opencv_stereo, write_opencv_stereo

WIDTH, HEIGHT = 1280, 960


def _random_opencv_rig(rng):
    """A random stereo rig in OpenCV's terms (5-term distortion, k3 included; T in metres)."""
    cams = []
    for _ in range(2):
        fx = rng.uniform(700, 1600)
        matrix = np.array([[fx, 0, rng.uniform(600, 680)], [0, fx * rng.uniform(0.97, 1.03), rng.uniform(440, 520)],
                           [0, 0, 1]])
        distortion = np.array([rng.uniform(-0.25, 0.05), rng.uniform(-0.05, 0.12), rng.uniform(-1e-3, 1e-3),
                               rng.uniform(-1e-3, 1e-3), rng.uniform(-0.03, 0.03)])
        cams.append((matrix, distortion))
    rvec = np.array([rng.uniform(-0.05, 0.05), rng.uniform(-0.25, 0.05), rng.uniform(-0.05, 0.05)])
    tvec = np.array([-rng.uniform(0.15, 0.6), rng.uniform(-0.02, 0.02), rng.uniform(-0.03, 0.03)])
    return cams, rvec, tvec


def _board_views(rng, cams, rvec, tvec, views=8):
    """Chessboard corners seen by both cameras (exact pixels, then a little noise)."""
    grid = np.array([[i * 0.04, j * 0.04, 0.0] for j in range(6) for i in range(9)], np.float32)
    objects, left, right = [], [], []
    rotation = cv2.Rodrigues(rvec)[0]
    for _ in range(views):
        board_r = cv2.Rodrigues(rng.uniform(-0.4, 0.4, 3))[0]
        board_t = np.array([rng.uniform(-0.3, 0.1), rng.uniform(-0.2, 0.1), rng.uniform(1.0, 2.0)])
        in_left = grid @ board_r.T + board_t
        pl, _ = cv2.projectPoints(in_left, np.zeros(3), np.zeros(3), *cams[0])
        pr, _ = cv2.projectPoints(in_left @ rotation.T + tvec, np.zeros(3), np.zeros(3), *cams[1])
        objects.append(grid)
        left.append((pl + rng.normal(0, 0.2, pl.shape)).astype(np.float32))
        right.append((pr + rng.normal(0, 0.2, pr.shape)).astype(np.float32))
    return objects, left, right


def _points_cv(rng, n=60):
    return np.column_stack([rng.uniform(-0.6, 0.6, n), rng.uniform(-0.45, 0.45, n), rng.uniform(1.2, 4.0, n)])


def _assert_projects_like_opencv(calibration, m1, d1, m2, d2, rotation, translation, rng):
    points_cv = _points_cv(rng)              # OpenCV's left camera frame (y down, z forward)
    points_ours = points_cv * [1, -1, -1]    # the same points in our rig frame (left camera, y up, −z)
    rig = calibration.rig(frame="rig")
    left_cv, _ = cv2.projectPoints(points_cv, np.zeros(3), np.zeros(3), m1, d1)
    right_cv, _ = cv2.projectPoints(points_cv, cv2.Rodrigues(np.asarray(rotation))[0], translation, m2, d2)
    np.testing.assert_allclose(rig.left.project(points_ours).pixels, left_cv.reshape(-1, 2), rtol=0, atol=1e-6)
    np.testing.assert_allclose(rig.right.project(points_ours).pixels, right_cv.reshape(-1, 2), rtol=0, atol=1e-6)


@pytest.mark.parametrize("seed", range(4))
def test_stereo_calibrate_output_imports_exactly(tmp_path, seed):
    """cv2.stereoCalibrate (k3 estimated, OpenCV's default) → the stereo sample's two files → USVIPS."""
    rng = np.random.default_rng(seed)
    cams, rvec, tvec = _random_opencv_rig(rng)
    objects, left, right = _board_views(rng, cams, rvec, tvec)
    rms, m1, d1, m2, d2, rotation, translation, _, _ = cv2.stereoCalibrate(
        objects, left, right, cams[0][0].copy(), cams[0][1].copy(), cams[1][0].copy(), cams[1][1].copy(),
        (WIDTH, HEIGHT), flags=cv2.CALIB_USE_INTRINSIC_GUESS)
    assert d1.size == 5 and d1.ravel()[4] != 0  # k3 estimated
    intrinsics, extrinsics = tmp_path / "intrinsics.yml", tmp_path / "extrinsics.yml"
    storage = cv2.FileStorage(str(intrinsics), cv2.FILE_STORAGE_WRITE)   # as OpenCV's stereo_calib sample
    for name, value in (("M1", m1), ("D1", d1), ("M2", m2), ("D2", d2)):
        storage.write(name, value)
    storage.release()
    storage = cv2.FileStorage(str(extrinsics), cv2.FILE_STORAGE_WRITE)
    r1, r2, p1, p2, q, _, _ = cv2.stereoRectify(m1, d1, m2, d2, (WIDTH, HEIGHT), rotation, translation)
    for name, value in (("R", rotation), ("T", translation), ("R1", r1), ("R2", r2), ("P1", p1), ("P2", p2),
                        ("Q", q)):
        storage.write(name, value)
    storage.release()
    calibration = read_opencv_stereo([intrinsics, extrinsics], size=(WIDTH, HEIGHT))
    _assert_projects_like_opencv(calibration, m1, d1, m2, d2, rotation, translation, rng)
    assert (calibration.left.width, calibration.left.height) == (WIDTH, HEIGHT)
    # through our own file and back out to OpenCV: the same numbers
    save_calibration(calibration, tmp_path / "cal.json")
    write_opencv_stereo(load_calibration(tmp_path / "cal.json"), tmp_path / "back.yml")
    storage = cv2.FileStorage(str(tmp_path / "back.yml"), cv2.FILE_STORAGE_READ)
    back = {k: storage.getNode(k).mat() for k in ("M1", "D1", "M2", "D2", "R", "T")}
    assert storage.getNode("image_width").real() == WIDTH
    storage.release()
    for name, original in (("M1", m1), ("D1", d1), ("M2", m2), ("D2", d2), ("R", rotation), ("T", translation)):
        np.testing.assert_allclose(back[name].ravel(), np.ravel(original), rtol=1e-12, atol=1e-14)


def _random_usvips_calibration(rng, housing=None):
    cameras = []
    for side in range(2):
        interior = Interior(f=rng.uniform(700, 1600), xp=rng.uniform(600, 680), yp=rng.uniform(440, 520),
                            sy=rng.uniform(0.97, 1.03), k1=rng.uniform(-0.25, 0.05), k2=rng.uniform(-0.05, 0.1),
                            p1=rng.uniform(-1e-3, 1e-3), p2=rng.uniform(-1e-3, 1e-3), k3=rng.uniform(-0.03, 0.03))
        exterior = Exterior(0, 0, 0) if side == 0 else Exterior(
            rng.uniform(0.15, 0.6), rng.uniform(-0.02, 0.02), rng.uniform(-0.03, 0.03),
            rng.uniform(-0.05, 0.05), rng.uniform(-0.2, 0.2), rng.uniform(-0.05, 0.05))
        kwargs = {} if housing is None else {"housing": housing}
        cameras.append(Camera(interior, exterior, width=WIDTH, height=HEIGHT, **kwargs))
    return StereoCalibration.from_cameras(*cameras, "air" if housing is None else "water", 0.4, station="rig")


@pytest.mark.parametrize("seed", range(4))
def test_export_projects_in_opencv_as_we_do(tmp_path, seed):
    rng = np.random.default_rng(100 + seed)
    calibration = _random_usvips_calibration(rng)
    left_out = write_opencv_stereo(calibration, tmp_path / "stereo.xml")
    assert left_out == []  # an in-air, one-station rig without sigmas loses nothing
    storage = cv2.FileStorage(str(tmp_path / "stereo.xml"), cv2.FILE_STORAGE_READ)
    arrays = {k: storage.getNode(k).mat() for k in ("M1", "D1", "M2", "D2", "R", "T")}
    storage.release()
    _assert_projects_like_opencv(calibration, arrays["M1"], arrays["D1"], arrays["M2"], arrays["D2"], arrays["R"],
                                 arrays["T"], rng)
    # and in again: the same calibration, with its sigma0 (written as OpenCV's 2-D RMS)
    again = read_opencv_stereo(tmp_path / "stereo.xml")
    assert again.sigma0_px == pytest.approx(calibration.sigma0_px) and again.sigma0_origin == "stated"
    for side in ("left", "right"):
        ours, theirs = getattr(calibration, side).interior, getattr(again, side).interior
        for name in ("f", "xp", "yp", "sy", "k1", "k2", "p1", "p2", "k3"):
            assert getattr(theirs, name) == pytest.approx(getattr(ours, name), rel=1e-12, abs=1e-15)


def test_the_pair_layout_is_written_and_read(tmp_path):
    calibration = _random_usvips_calibration(np.random.default_rng(7))
    write_opencv_stereo(calibration, tmp_path)
    storage = cv2.FileStorage(str(tmp_path / "intrinsics.yml"), cv2.FILE_STORAGE_READ)
    assert set(storage.root().keys()) >= {"M1", "D1", "M2", "D2"} and storage.getNode("R").empty()
    storage.release()
    storage = cv2.FileStorage(str(tmp_path / "extrinsics.yml"), cv2.FILE_STORAGE_READ)
    assert set(storage.root().keys()) >= {"R", "T", "R1", "R2", "P1", "P2", "Q"}
    storage.release()
    again = read_opencv_stereo([tmp_path / "intrinsics.yml", tmp_path / "extrinsics.yml"])
    points = _points_cv(np.random.default_rng(8)) * [1, -1, -1]
    np.testing.assert_allclose(again.rig(frame="rig").right.project(points).pixels,
                               calibration.rig(frame="rig").right.project(points).pixels, atol=1e-6)


def test_export_of_a_refractive_calibration_says_what_is_left_out(tmp_path):
    housing = FlatPortHousing(0.0, 0.0, 0.05, 0.01, 1.5, 1.34)
    calibration = _random_usvips_calibration(np.random.default_rng(3), housing)
    left_out = write_opencv_stereo(calibration, tmp_path / "stereo.yml")
    assert any("flat-port housing is left out" in line for line in left_out)
    assert all("\n" not in line for line in left_out)


def test_npz_and_millimetres(tmp_path):
    rng = np.random.default_rng(11)
    cams, rvec, tvec = _random_opencv_rig(rng)
    rotation = cv2.Rodrigues(rvec)[0]
    np.savez(tmp_path / "stereo.npz", K1=cams[0][0], D1=cams[0][1], K2=cams[1][0], D2=cams[1][1], R=rotation,
             T=tvec * 1000.0, image_size=np.array([WIDTH, HEIGHT]))
    calibration = read_opencv_stereo(tmp_path / "stereo.npz", unit="mm")
    _assert_projects_like_opencv(calibration, cams[0][0], cams[0][1], cams[1][0], cams[1][1], rotation, tvec, rng)
    assert calibration.left.width == WIDTH


def _write(path, **arrays):
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for name, value in arrays.items():
        storage.write(name, value)
    storage.release()
    return path


GOOD = dict(M1=np.array([[810.0, 0, 641.5], [0, 798.0, 478.25], [0, 0, 1]]),
            D1=np.array([[-0.12, 0.03, 1e-3, 0, 0.01]]),
            M2=np.array([[805.0, 0, 630.0], [0, 801.0, 482.0], [0, 0, 1]]), D2=np.array([[-0.10, 0.02, 0, 1e-3]]),
            R=cv2.Rodrigues(np.array([0.01, -0.09, 0.004]))[0], T=np.array([[-0.39], [0.006], [0.012]]))


@pytest.mark.parametrize("change, message", [
    ({"D1": np.array([[-0.1, 0.02, 0, 0, 0.05, 0.1, 0, 0]])}, "rational model .*k4=0.1"),
    ({"D2": np.array([[-0.1, 0.02, 0, 0, 0, 0, 0, 0, 0.01, 0, 0, 0]])}, "thin-prism model .*s1=0.01"),
    ({"D1": np.array([[-0.1, 0.02, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0.002, 0]])}, "tilted-sensor model .*taux"),
    ({"D1": np.array([[-0.1, 0.02, 0]])}, "4, 5, 8, 12 or 14"),
    ({"R": np.array([[1.0, 0.1, 0], [0, 1, 0], [0, 0, 1]])}, "R is not a rotation"),
    ({"R": np.diag([1.0, 1.0, -1.0])}, r"R is not a rotation .*det R = -1"),
    ({"M1": np.array([[810.0, 3.0, 641.5], [0, 798.0, 478.25], [0, 0, 1]])}, "skew"),
    ({"T": np.zeros((3, 1))}, "T is zero"),
    ({"T": np.array([[1e-9], [0.0], [0.0]])}, "T puts the cameras 1e-09 m apart"),
    ({"D1": np.array([[-0.1, np.nan, 0, 0, 0]])}, "distortion vector holds nan at position 2 of 5"),
    ({"T": np.array([[-0.39], [np.inf], [0.0]])}, "T holds inf at position 2 of 3"),
    ({"M2": np.array([[805.0, 0, np.nan], [0, 801.0, 482.0], [0, 0, 1]])}, r"right camera .*holds nan at position 3"),
])
def test_bad_files_are_refused_in_one_line(tmp_path, change, message):
    path = _write(tmp_path / "bad.yml", **(GOOD | change))
    with pytest.raises(InputFileError, match=message) as caught:
        read_opencv_stereo(path)
    assert "\n" not in str(caught.value) and "bad.yml" in str(caught.value)


def test_zero_extra_terms_are_accepted(tmp_path):
    path = _write(tmp_path / "eight.yml", **(GOOD | {"D1": np.array([[-0.12, 0.03, 1e-3, 0, 0.01, 0, 0, 0]])}))
    assert read_opencv_stereo(path).left.interior.k3 == pytest.approx(0.01)


def test_missing_fields_sizes_and_junk_are_refused(tmp_path):
    intrinsics = _write(tmp_path / "intrinsics.yml", **{k: GOOD[k] for k in ("M1", "D1", "M2", "D2")},
                        image_width=1280, image_height=960)
    with pytest.raises(InputFileError, match="missing R, T .*give both files"):
        read_opencv_stereo(intrinsics)
    extrinsics = _write(tmp_path / "extrinsics.yml", R=GOOD["R"], T=GOOD["T"], image_width=640, image_height=480)
    with pytest.raises(InputFileError, match="mismatched image sizes: 640x480 here, 1280x960"):
        read_opencv_stereo([intrinsics, extrinsics])
    extrinsics = _write(tmp_path / "extrinsics.yml", R=GOOD["R"], T=GOOD["T"])
    assert read_opencv_stereo([intrinsics, extrinsics]).right.width == 1280
    with pytest.raises(InputFileError, match="mismatched image sizes: the file says 1280x960, the given image size is"):
        read_opencv_stereo([intrinsics, extrinsics], size=(640, 480))
    (tmp_path / "junk.yml").write_text("not: [a, calibration")
    with pytest.raises(InputFileError):
        read_opencv_stereo(tmp_path / "junk.yml")
    with pytest.raises(InputFileError, match="no such file"):
        read_opencv_stereo(tmp_path / "absent.yml")
    with pytest.raises(InvalidParameterError, match="unit of T: must be one of"):
        read_opencv_stereo(_write(tmp_path / "good.yml", **GOOD), unit="furlong")


@pytest.mark.parametrize("damage, message", [
    (lambda text: text.replace("rows: 3", "rows: 4", 1), "entry 'M1': its data hold 9 numbers, its size says 12"),
    (lambda text: text.replace("rows: 3", "rows: 3000000000", 1), "entry 'M1': a matrix of 3000000000"),
    (lambda text: text.replace("data: [", "data: [ abc, ", 1), "entry 'M1': its data hold 10 numbers"),
    (lambda text: text.replace("data: [ 810.", "data: [ abc", 1), "entry 'M1': its data hold something that is not"),
    (lambda text: text.replace("   cols: 3\n", "", 1), "entry 'M1': a matrix without its rows and cols"),
    (lambda text: "%YAML:1.0\n---\n- 1\n- 2\n", "named entries at its top level"),
])
def test_damaged_matrices_are_refused_in_one_line(tmp_path, damage, message):
    """A hand-edited or truncated file: OpenCV's own assertion, a 50 GB allocation or (a missing cols) a
    corrupted heap that ends the process becomes one line naming the file and the entry."""
    path = _write(tmp_path / "good.yml", **GOOD)
    path.write_text(damage(path.read_text()))
    with pytest.raises(InputFileError, match=message) as caught:
        read_opencv_stereo(path)
    assert "\n" not in str(caught.value) and "good.yml" in str(caught.value)


@pytest.mark.parametrize("t_value, unit, hint", [
    (-120.0, "m", "mm or cm"), (-0.39, "m", None), (-390.0, "mm", None),
    (-0.39, "mm", "m"), (-4000.0, "m", "mm"), (-1e6, "mm", ""),
])
def test_an_implausible_baseline_says_which_unit_would_fit(tmp_path, t_value, unit, hint):
    """OpenCV's T is in the board's unit, which the file does not say: a baseline no stereo rig has is
    flagged with the unit that makes it plausible."""
    from usvips.io.opencv_calibration import baseline_doubt

    path = _write(tmp_path / "stereo.yml", **(GOOD | {"T": np.array([[t_value], [0.0], [0.0]])}))
    doubt = baseline_doubt(read_opencv_stereo(path, unit=unit), unit)
    if hint is None:
        assert doubt is None
    else:
        assert doubt is not None and "outside the 0.01–5 m of stereo rigs" in doubt and doubt.endswith(
            f"{hint}?" if hint else unit), doubt


@pytest.mark.parametrize("where", ["name", "value"])
def test_bytes_that_are_not_utf8_in_a_name_or_a_value_are_one_line(tmp_path, where):
    """OpenCV hands a YAML entry's name and a string value over undecoded: a byte that is not UTF-8 there
    (a damaged copy) is refused by name, not an internal UnicodeDecodeError."""
    text = (b"%YAML 1.2\n---\nM1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
            b"   data: [ 810., 0., 641.5, 0., 798., 478.25, 0., 0., 1. ]\n")
    text += b"\x80M2: 1\n" if where == "name" else b"note: \"\x80\"\n"
    path = tmp_path / "stereo.yml"
    path.write_bytes(text)
    with pytest.raises(InputFileError, match="stereo.yml"):
        read_opencv_stereo([path], (1280, 960))


@pytest.mark.parametrize("seed", range(3))
def test_the_residual_a_file_states_is_its_sigma0_and_one_that_states_none_is_marked_assumed_everywhere(tmp_path,
                                                                                                        seed):
    """cv2.stereoCalibrate's RMS is of the 2-D reprojection error: corners with 0.2 px noise per coordinate
    give an RMS near 0.28 px, and the import's sigma0 (per coordinate) near 0.2 px, marked 'stated'. Per-view
    errors (OpenCV's calibration sample) serve the same way. A file without a residual gets 0.5 px marked
    'assumed' (kept through our own file), and every figure measured with it says so, and that its sigma
    holds pointing only (an OpenCV file has no covariance)."""
    from usvips.core.measurements import measure_picks
    from usvips.core.measurements.breakdown import breakdown_cells

    rng = np.random.default_rng(seed)
    cams, rvec, tvec = _random_opencv_rig(rng)
    objects, left, right = _board_views(rng, cams, rvec, tvec, views=12)
    rms, m1, d1, m2, d2, rotation, translation, _, _ = cv2.stereoCalibrate(
        objects, left, right, cams[0][0].copy(), cams[0][1].copy(), cams[1][0].copy(), cams[1][1].copy(),
        (WIDTH, HEIGHT), flags=cv2.CALIB_USE_INTRINSIC_GUESS)
    arrays = (("M1", m1), ("D1", d1), ("M2", m2), ("D2", d2), ("R", rotation), ("T", translation))

    def written(name, extra):
        storage = cv2.FileStorage(str(tmp_path / name), cv2.FILE_STORAGE_WRITE)
        for key, value in (*arrays, *extra):
            storage.write(key, value)
        storage.release()
        return tmp_path / name

    stated = read_opencv_stereo(written("rms.yml", [("rms", rms)]), size=(WIDTH, HEIGHT))
    assert stated.sigma0_origin == "stated" and stated.sigma0_px == pytest.approx(rms / np.sqrt(2), rel=1e-12)
    assert 0.15 < stated.sigma0_px < 0.25, (rms, stated.sigma0_px)  # the corners' 0.2 px per coordinate
    views = np.array([rms * 0.9, rms * 1.1])
    per_view = read_opencv_stereo(written("views.yml", [("per_view_reprojection_errors", views)]),
                                  size=(WIDTH, HEIGHT))
    assert per_view.sigma0_origin == "stated"
    assert per_view.sigma0_px == pytest.approx(np.sqrt(np.mean(views ** 2)) / np.sqrt(2))
    given = read_opencv_stereo(written("given.yml", [("rms", rms)]), size=(WIDTH, HEIGHT), sigma0_px=2.95)
    assert (given.sigma0_origin, given.sigma0_px) == ("given", 2.95)
    save_calibration(read_opencv_stereo(written("bare.yml", []), size=(WIDTH, HEIGHT)), tmp_path / "bare.json")
    bare = load_calibration(tmp_path / "bare.json")
    assert (bare.sigma0_origin, bare.sigma0_px) == ("assumed", 0.5)
    points = _points_cv(rng, 2) * [1, -1, -1]
    rig = bare.rig(frame="rig")
    m = measure_picks("length", bare, rig.left.project(points).pixels, rig.right.project(points).pixels, 0, "rig")
    notes = breakdown_cells(m)["sigma_notes"]
    assert "assumed" in notes and "pointing only" in notes and m.main.sigma_calibration == 0.0
    assert not any("assumed" in mark for mark in measure_picks("length", stated, rig.left.project(points).pixels,
                                                               rig.right.project(points).pixels, 0, "rig").marks)
    with pytest.raises(InputFileError, match="rms"):
        read_opencv_stereo(written("bad.yml", [("rms", -1.0)]), size=(WIDTH, HEIGHT))


def _write_camera(path, matrix, distortion, residual=None):
    """One camera's file as OpenCV's calibration sample writes it."""
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    storage.write("image_width", 1280)
    storage.write("image_height", 960)
    storage.write("camera_matrix", matrix)
    storage.write("distortion_coefficients", distortion)
    if residual is not None:
        storage.write("avg_reprojection_error", residual)
    storage.release()
    return path


def test_each_cameras_own_file_then_r_and_t_is_the_same_rig_as_one_stereo_file(tmp_path):
    """Left camera's file, right camera's file (OpenCV's calibration sample), then R and T: the same
    calibration as the one stereo file; sigma0 from the files' residuals; a stereo residual wins."""
    one = read_opencv_stereo(_write(tmp_path / "stereo.yml", **GOOD), size=(1280, 960), sigma0_px=0.3)
    left = _write_camera(tmp_path / "left.yml", GOOD["M1"], GOOD["D1"], residual=0.3)
    right = _write_camera(tmp_path / "right.yml", GOOD["M2"], GOOD["D2"], residual=0.5)
    extrinsics = _write(tmp_path / "extrinsics.yml", R=GOOD["R"], T=GOOD["T"])
    three = read_opencv_stereo([left, right, extrinsics])
    for camera in ("left", "right"):
        assert getattr(three, camera).interior == getattr(one, camera).interior
    points = np.array([[0.1, -0.2, -2.0], [-0.3, 0.1, -3.5]])
    np.testing.assert_allclose(three.rig(0).right.project(points).pixels, one.rig(0).right.project(points).pixels,
                               atol=1e-9)
    assert three.sigma0_origin == "stated"
    assert three.sigma0_px == pytest.approx(np.sqrt((0.3 ** 2 + 0.5 ** 2) / 2) / np.sqrt(2))
    stereo_residual = _write(tmp_path / "ext_rms.yml", R=GOOD["R"], T=GOOD["T"], rms=0.8)
    assert read_opencv_stereo([left, right, stereo_residual]).sigma0_px == pytest.approx(0.8 / np.sqrt(2))


def test_one_cameras_file_alone_or_three_of_them_are_refused_by_name(tmp_path):
    left = _write_camera(tmp_path / "left.yml", GOOD["M1"], GOOD["D1"])
    extrinsics = _write(tmp_path / "extrinsics.yml", R=GOOD["R"], T=GOOD["T"])
    with pytest.raises(InputFileError, match="missing K2, D2 .*give the right camera's file after the left"):
        read_opencv_stereo([left, extrinsics])
    with pytest.raises(InputFileError, match="left.yml: a third file of one camera's calibration"):
        read_opencv_stereo([left, left, left, extrinsics])
    storage = cv2.FileStorage(str(tmp_path / "bare.yml"), cv2.FILE_STORAGE_WRITE)
    storage.write("camera_matrix", GOOD["M1"])
    storage.release()
    with pytest.raises(InputFileError, match="bare.yml: a camera matrix without its distortion"):
        read_opencv_stereo([tmp_path / "bare.yml", left, extrinsics])


def _ros_camera_info(path, matrix, distortion, rectification, projection, model="plumb_bob"):
    """One camera's file as ROS's camera_calibration writes it (plain YAML: rows, cols, data; no dt)."""
    def block(name, value):
        value = np.asarray(value, dtype=np.float64)
        rows, cols = (1, value.size) if value.ndim == 1 or value.shape[0] == 1 else value.shape
        numbers = ", ".join(repr(float(v)) for v in value.ravel())
        return f"{name}:\n  rows: {rows}\n  cols: {cols}\n  data: [{numbers}]\n"

    path.write_text(f"image_width: {WIDTH}\nimage_height: {HEIGHT}\ncamera_name: narrow_stereo/{path.stem}\n"
                    + block("camera_matrix", matrix) + f"distortion_model: {model}\n"
                    + block("distortion_coefficients", distortion) + block("rectification_matrix", rectification)
                    + block("projection_matrix", projection))
    return path


@pytest.mark.parametrize("seed", range(6))
def test_a_ros_camera_info_pair_is_the_rig_its_rectification_came_from(tmp_path, seed):
    """Random OpenCV rigs rectified by cv2.stereoRectify and written as ROS's two camera_info files: R and
    T recovered from the rectification rotations and projection matrices give OpenCV's own projections."""
    rng = np.random.default_rng(100 + seed)
    cams, rvec, tvec = _random_opencv_rig(rng)
    rotation = cv2.Rodrigues(rvec)[0]
    r1, r2, p1, p2, *_ = cv2.stereoRectify(cams[0][0], cams[0][1], cams[1][0], cams[1][1], (WIDTH, HEIGHT),
                                           rotation, tvec.reshape(3, 1), alpha=rng.uniform(0, 1))
    left = _ros_camera_info(tmp_path / "left.yaml", cams[0][0], cams[0][1], r1, p1)
    right = _ros_camera_info(tmp_path / "right.yaml", cams[1][0], cams[1][1], r2, p2)
    calibration = read_opencv_stereo([left, right])
    _assert_projects_like_opencv(calibration, cams[0][0], cams[0][1], cams[1][0], cams[1][1], rotation, tvec, rng)
    assert (calibration.left.width, calibration.left.height) == (WIDTH, HEIGHT)
    with pytest.raises(InputFileError, match="the first camera_info file is the right camera's"):
        read_opencv_stereo([right, left])  # given the other way round: refused, not a swapped rig


def test_a_ros_fisheye_model_or_a_broken_projection_is_refused_by_name(tmp_path):
    matrix, distortion = GOOD["M1"], np.array([-0.1, 0.02, 0.0, 0.0, 0.0])
    shifted = np.hstack([GOOD["M2"], np.array([[-300.0], [0.0], [0.0]])])
    plain = np.hstack([GOOD["M1"], np.zeros((3, 1))])
    right = _ros_camera_info(tmp_path / "right.yaml", GOOD["M2"], distortion, np.eye(3), shifted)
    fisheye = _ros_camera_info(tmp_path / "left.yaml", matrix, distortion[:4], np.eye(3), plain, model="equidistant")
    with pytest.raises(InputFileError, match="left.yaml: distortion_model 'equidistant' is not supported"):
        read_opencv_stereo([fisheye, right])
    flat = _ros_camera_info(tmp_path / "flat.yaml", matrix, distortion, np.eye(3), np.zeros((3, 4)))
    with pytest.raises(InputFileError, match="left camera's projection_matrix has no inverse"):
        read_opencv_stereo([flat, right])
    skewed = _ros_camera_info(tmp_path / "skewed.yaml", matrix, distortion, np.diag([1.0, 1.0, 2.0]), plain)
    with pytest.raises(InputFileError, match="left camera's rectification_matrix: R is not a rotation"):
        read_opencv_stereo([skewed, right])


def _write_with(path, strings: dict[str, str] | None = None, numbers: dict[str, float] | None = None, **arrays):
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for name, value in arrays.items():
        storage.write(name, value)
    for name, value in (strings or {}).items():
        storage.write(name, value)
    for name, value in (numbers or {}).items():
        storage.write(name, value)
    storage.release()
    return path


@pytest.mark.parametrize(("strings", "numbers", "message"), [
    ({"distortion_model": "fisheye"}, None, "distortion_model 'fisheye' is not supported"),
    ({"distortion_model": "equidistant"}, None, "distortion_model 'equidistant' is not supported"),
    ({"camera_model": "omni"}, None, "camera_model 'omni' is not supported"),
    (None, {"fisheye_model": 1}, r"a fisheye calibration \(fisheye_model: 1"),
])
def test_a_fisheye_or_omnidirectional_calibration_is_refused_never_read_as_brown(tmp_path, strings, numbers,
                                                                                 message):
    """A stereo file from cv2.fisheye (four distortion numbers, as Brown's k1, k2, p1, p2 would be) that
    says its model: refused by name, in a stereo file or a camera's own file."""
    fisheye = GOOD | {"D1": np.array([[0.05, -0.01, 0.002, -0.0005]]), "D2": np.array([[0.04, -0.01, 0.001, 0.0]])}
    path = _write_with(tmp_path / "fisheye.yml", strings, numbers, **fisheye)
    with pytest.raises(InputFileError, match=message):
        read_opencv_stereo(path)
    left = _write_with(tmp_path / "left.yml", strings, numbers, camera_matrix=GOOD["M1"],
                       distortion_coefficients=fisheye["D1"])
    right = _write(tmp_path / "right.yml", camera_matrix=GOOD["M2"], distortion_coefficients=fisheye["D2"])
    extrinsics = _write(tmp_path / "rt.yml", R=GOOD["R"], T=GOOD["T"])
    with pytest.raises(InputFileError, match=message):
        read_opencv_stereo([left, right, extrinsics])
    for model in ("plumb_bob", "radtan"):  # Brown's, by ROS's and Kalibr's names
        assert read_opencv_stereo(_write_with(tmp_path / f"{model}.yml", {"distortion_model": model}, **GOOD))


def test_other_tools_entries_are_not_read_and_conflicting_ones_are_refused(tmp_path):
    """A board description, a ROS header (maps that are no matrices) and a long list of image points are
    another tool's: the file still imports, quickly. Two names for one matrix, or two image sizes, that
    disagree are refused rather than one chosen."""
    from usvips.io.opencv_calibration import _read_file

    path = _write(tmp_path / "plus.yml", **GOOD, image_width=1280, image_height=960)
    text = path.read_text() + "board:\n   width: 9\n   height: 6\nheader:\n   frame_id: cam\nimage_points: [ " + \
        ", ".join(["1.5"] * 60000) + " ]\n"
    path.write_text(text)
    assert read_opencv_stereo(path).left.width == 1280
    assert not {"board", "header", "image_points"} & set(_read_file(path))  # (a long list read took minutes)
    twice = _write(tmp_path / "twice.yml", **GOOD, cameraMatrix1=GOOD["M2"])
    with pytest.raises(InputFileError, match="M1 and cameraMatrix1 both give K1 and differ"):
        read_opencv_stereo(twice)
    assert read_opencv_stereo(_write(tmp_path / "same.yml", **GOOD, cameraMatrix1=GOOD["M1"]))
    sizes = _write(tmp_path / "sizes.yml", **GOOD, image_width=1920, image_height=1080,
                   image_size=np.array([1280, 720]))
    with pytest.raises(InputFileError, match="states two image sizes: image_width/image_height 1920x1080, "
                                             "image_size 1280x720"):
        read_opencv_stereo(sizes)
    with pytest.raises(InputFileError, match="from 1 to 65536"):
        read_opencv_stereo(_write(tmp_path / "huge.yml", **GOOD, image_width=10**9, image_height=1080))


def test_whole_number_matrices_that_hold_fractions_empty_bom_and_utf16_files(tmp_path):
    path = _write(tmp_path / "good.yml", **GOOD)
    text = path.read_text()
    declared = tmp_path / "declared.yml"
    declared.write_text(text.replace("dt: d", "dt: i", 1))  # M1's data are 810., 641.5 …: rounded by OpenCV
    with pytest.raises(InputFileError, match=r"entry 'M1': it declares whole numbers \(dt: i\) but holds 641.5"):
        read_opencv_stereo(declared)
    whole = tmp_path / "whole.yml"
    whole.write_text(text.replace("641.5", "641.").replace("478.25", "478.").replace("dt: d", "dt: i", 1))
    assert read_opencv_stereo(whole).left.interior.xp == pytest.approx(641.0)
    (tmp_path / "empty.yml").write_bytes(b"")
    with pytest.raises(InputFileError, match="empty.yml: the file is empty$"):
        read_opencv_stereo(tmp_path / "empty.yml")
    (tmp_path / "bom.yml").write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert read_opencv_stereo(tmp_path / "bom.yml").left.interior.f == pytest.approx(810.0)
    (tmp_path / "utf16.yml").write_bytes(text.encode("utf-16"))
    with pytest.raises(InputFileError, match="is UTF-16 text, not UTF-8"):
        read_opencv_stereo(tmp_path / "utf16.yml")
    np.save(tmp_path / "single.npy", GOOD["M1"])
    (tmp_path / "single.npy").rename(tmp_path / "single.npz")
    with pytest.raises(InputFileError, match=r"not a .npz archive \(a single array saved by np.save"):
        read_opencv_stereo(tmp_path / "single.npz")


def test_a_calibration_given_to_the_wrong_door_is_named_for_what_it_is(tmp_path):
    """A USVIPS calibration given to the OpenCV import, and an OpenCV one where a USVIPS one is read."""
    rng = np.random.default_rng(3)
    save_calibration(_random_usvips_calibration(rng), tmp_path / "ours.json")
    with pytest.raises(InputFileError, match="ours.json: is already a USVIPS calibration"):
        read_opencv_stereo(tmp_path / "ours.json")
    for name in ("theirs.yml", "theirs.xml"):
        _write(tmp_path / name, **GOOD)
        with pytest.raises(InputFileError, match=f"{name}: an OpenCV calibration .YAML/XML., not a USVIPS one: "
                                                 "convert it first with usvips calibration import"):
            load_calibration(tmp_path / name)
