"""DLT coefficient files from other tools (issue 33, item 9): both layouts, the tools' pixel origins, a
stated RMS as sigma0 (else marked assumed), line-numbered errors; the rig reproduces the known cameras'
projections."""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.test_dlt_camera import coefficients_of, dlt_pixels, points_in_view, random_camera
from usvips.core.errors import InputFileError, InvalidParameterError
from usvips.io.calibration_file import load_calibration, save_calibration
from usvips.io.dlt_coefficients import calibration_from_dlt, read_coefficients

HEIGHT = 960


def _rig(seed: int, skew: float = 0.0):
    rng = np.random.default_rng(seed)
    cameras = []
    for _ in range(2):
        k, pose, _ = random_camera(rng)
        k[0, 1] = skew
        cameras.append((k, pose))
    return rng, cameras


def _as_tool(coefficients: np.ndarray, origin: str, one_based: bool) -> np.ndarray:
    """The coefficients as the tool writes them (its pixels: y up from the bottom, first pixel 1)."""
    matrix = np.append(coefficients, 1.0).reshape(3, 4)
    shift = 1.0 if one_based else 0.0
    change = np.eye(3)
    change[0, 2] = shift
    if origin == "bottom-left":
        change[1, 1], change[1, 2] = -1.0, HEIGHT - 1.0 + shift
    else:
        change[1, 2] = shift
    tool = change @ matrix
    return (tool / tool[2, 3]).ravel()[:11]


@pytest.mark.parametrize("origin, one_based, layout", [("top-left", False, "columns"), ("bottom-left", True, "columns"),
                                                      ("bottom-left", False, "rows")])
def test_a_known_rig_is_read_back_in_every_layout_and_origin(tmp_path, origin, one_based, layout):
    for seed in range(5):
        rng, cameras = _rig(seed)
        ours = [coefficients_of(k, pose) for k, pose in cameras]
        table = np.array([_as_tool(c, origin, one_based) for c in ours])
        path = tmp_path / f"dlt{seed}.csv"
        rows = table.T if layout == "columns" else table
        path.write_text("\n".join(",".join(f"{v:.17g}" for v in row) for row in rows) + "\n")
        calibration, _ = calibration_from_dlt(path, origin=origin, one_based=one_based, size=(1280, HEIGHT))
        save_calibration(calibration, tmp_path / "cal.json")
        rig = load_calibration(tmp_path / "cal.json").rig("dlt")
        points = points_in_view(cameras[0][1], rng)
        for camera, coefficients in zip((rig.left, rig.right), ours, strict=True):
            seen = camera.project(points)
            assert np.abs(seen.pixels - dlt_pixels(coefficients, points)).max() < 1e-6
        assert calibration.sigma0_origin == "assumed" and calibration.sigma0_px == 0.5
        assert calibration.source["origin"] == origin and calibration.source["one_based"] == one_based


def test_skew_is_dropped_and_its_effect_stated_and_a_stated_rms_is_sigma0(tmp_path):
    _, cameras = _rig(7, skew=4.0)
    table = np.array([coefficients_of(k, pose) for k, pose in cameras])
    path = tmp_path / "argus-dlt-coefs.csv"
    path.write_text("# from a wand calibration\n# rms_px: 0.42\ncam1\tcam2\n"
                    + "\n".join("\t".join(f"{v:.17g}" for v in row) for row in table.T) + "\n")
    calibration, decomposed = calibration_from_dlt(path, size=(1280, HEIGHT))
    assert decomposed["left"].skew == pytest.approx(4.0)
    effect = calibration.statistics["skew_px"]["left"]
    assert effect["top"] > effect["middle"] > 0 and effect["bottom"] > effect["middle"]
    assert calibration.sigma0_px == 0.42 and calibration.sigma0_origin == "stated"


@pytest.mark.parametrize("text, message", [
    ("1,2,3\n4,x,6\n", "line 2: 'x' is not a number"),
    ("1,2\n3\n", "line 2: 1 values where line 1 has 2"),
    ("1,2\n" * 10, "10 rows of 2 values: a DLT has 11"),
    ("# rms_px: -1\n", "line 1: rms_px must be a positive number"),
    ("", "holds no DLT coefficients"),
    ("1,nan\n" * 11, "line 1: holds a value that is not finite"),
])
def test_bad_files_name_the_line(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputFileError, match=message):
        read_coefficients(path)


def test_bad_choices_are_named(tmp_path):
    _, cameras = _rig(3)
    path = tmp_path / "dlt.csv"
    path.write_text("\n".join(",".join(f"{v:.17g}" for v in row)
                              for row in np.array([coefficients_of(k, p) for k, p in cameras]).T) + "\n")
    with pytest.raises(InvalidParameterError, match="cameras"):
        calibration_from_dlt(path, cameras=(1, 3))
    with pytest.raises(InvalidParameterError, match="image height"):
        calibration_from_dlt(path, origin="bottom-left")
    one = tmp_path / "one.csv"
    one.write_text("\n".join(f"{v:.17g}" for v in coefficients_of(*cameras[0])) + "\n")
    with pytest.raises(InputFileError, match="one camera"):
        calibration_from_dlt(one)


def test_quoted_numbers_are_read_and_a_second_header_decimal_commas_and_separators_are_refused(tmp_path):
    _, cameras = _rig(3)
    table = np.array([coefficients_of(k, pose) for k, pose in cameras])
    rows = ["\t".join(f"{v:.17g}" for v in row) for row in table.T]
    quoted = tmp_path / "quoted.csv"
    quoted.write_text('"cam1","cam2"\n' + "\n".join(",".join(f'"{v}"' for v in r.split("\t")) for r in rows) + "\n")
    plain = tmp_path / "plain.csv"
    plain.write_text("cam1,cam2\n" + "\n".join(r.replace("\t", ",") for r in rows) + "\n")
    read, _ = calibration_from_dlt(quoted, size=(1280, HEIGHT))
    again, _ = calibration_from_dlt(plain, size=(1280, HEIGHT))
    assert read.left.interior.f == again.left.interior.f
    for name, text, message in (
            ("headers.csv", "cam1,cam2\nx,y\n" + "\n".join(rows), "headers.csv line 2: 'x' is not a number"),
            ("comma.csv", "cam1;cam2\n" + "\n".join(r.replace(".", ",").replace("\t", ";") for r in rows),
             "comma.csv line 2: fields separated by semicolons with decimal commas"),
            ("underscore.csv", "\n".join(rows).replace("\t", ",1_0,", 1),
             "underscore.csv line 1: '1_0' is not a number"),
    ):
        (tmp_path / name).write_text(text + "\n")
        with pytest.raises(InputFileError, match=message):
            calibration_from_dlt(tmp_path / name, size=(1280, HEIGHT))
    (tmp_path / "zeros.csv").write_text("\n".join(["0,0"] * 11) + "\n")
    with pytest.raises(InputFileError, match=r"zeros.csv: camera 1: the DLT coefficients are singular") as caught:
        calibration_from_dlt(tmp_path / "zeros.csv", size=(1280, HEIGHT))
    assert str(caught.value).count("zeros.csv") == 1
