"""``usvips calibration import|export``: OpenCV files in and out, warnings and bad input on one line."""

import csv
from pathlib import Path

import cv2
import numpy as np
import pytest

from usvips.cli import main
from usvips.io.calibration_file import load_calibration

M1 = np.array([[1210.0, 0, 641.5], [0, 1204.0, 478.25], [0, 0, 1]])
M2 = np.array([[1190.0, 0, 630.0], [0, 1195.0, 482.0], [0, 0, 1]])
D1 = np.array([[-0.12, 0.03, 1e-3, -4e-4, 0.011]])
D2 = np.array([[-0.10, 0.02, 2e-4, 1e-3, -0.008]])
R = cv2.Rodrigues(np.array([0.01, -0.09, 0.004]))[0]
T = np.array([[-390.0], [6.0], [12.0]])  # millimetres, as a board measured in mm gives
SAMPLES = Path(__file__).resolve().parents[2] / "sample_projects"


def _write(path, **arrays):
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for name, value in arrays.items():
        storage.write(name, value)
    storage.release()
    return str(path)


def test_import_the_pair_and_export_again(tmp_path, capsys):
    intrinsics = _write(tmp_path / "intrinsics.yml", M1=M1, D1=D1, M2=M2, D2=D2)
    extrinsics = _write(tmp_path / "extrinsics.yml", R=R, T=T)
    out = tmp_path / "cal.json"
    assert main(["calibration", "import", intrinsics, extrinsics, "--out", str(out), "--image-size", "1280x960",
                 "--unit", "mm"]) == 0
    printed = capsys.readouterr().out
    assert "baseline 0.3902 m" in printed
    assert "sigma0 0.5 px ASSUMED" in printed and "--sigma0 PX" in printed  # the files state no residual
    calibration = load_calibration(out)
    assert calibration.sigma0_origin == "assumed"
    assert calibration.left.interior.k3 == pytest.approx(0.011) and calibration.right.width == 1280
    assert main(["calibration", "export", str(out), "--format", "opencv", "--out", str(tmp_path / "back.yml")]) == 0
    assert capsys.readouterr().err == ""  # nothing left out of an imported in-air rig
    storage = cv2.FileStorage(str(tmp_path / "back.yml"), cv2.FILE_STORAGE_READ)
    np.testing.assert_allclose(storage.getNode("T").mat(), T / 1000.0, rtol=1e-12)
    np.testing.assert_allclose(storage.getNode("D1").mat(), D1, rtol=1e-12, atol=1e-17)
    storage.release()


def test_import_takes_sigma0_from_the_stated_rms_or_as_given_and_figures_say_an_assumed_one(tmp_path, capsys):
    stated = _write(tmp_path / "stated.yml", M1=M1, D1=D1, M2=M2, D2=D2, R=R, T=T, rms=4.1719)
    assert main(["calibration", "import", stated, "--out", str(tmp_path / "stated.json"), "--image-size",
                 "1280x960", "--unit", "mm"]) == 0
    assert "sigma0 2.95 px from the file (rms 4.172 px" in capsys.readouterr().out
    assert load_calibration(tmp_path / "stated.json").sigma0_origin == "stated"
    assert main(["calibration", "import", stated, "--out", str(tmp_path / "given.json"), "--image-size",
                 "1280x960", "--unit", "mm", "--sigma0", "1.5"]) == 0
    assert "sigma0 1.5 px (given)" in capsys.readouterr().out
    bare = _write(tmp_path / "bare.yml", M1=M1, D1=D1, M2=M2, D2=D2, R=R, T=T)
    assert main(["calibration", "import", bare, "--out", str(tmp_path / "bare.json"), "--image-size", "1280x960",
                 "--unit", "mm"]) == 0
    capsys.readouterr()
    rig = load_calibration(tmp_path / "bare.json").rig(frame="rig")
    ends = np.array([[0.0, 0.0, -2.0], [0.3, 0.05, -2.1]])
    pixels = np.hstack([rig.left.project(ends).pixels, rig.right.project(ends).pixels])
    (tmp_path / "obs.csv").write_text("id,xl,yl,xr,yr\n1," + ",".join(map(str, pixels[0])) + "\n")
    (tmp_path / "picks.csv").write_text("object,type,vertex,xl,yl,xr,yr\n" + "".join(
        f"f,length,{v}," + ",".join(map(str, pixels[v])) + "\n" for v in range(2)))
    assert main(["intersect", "--calibration", str(tmp_path / "bare.json"), "--obs", str(tmp_path / "obs.csv"),
                 "--out", str(tmp_path / "points.csv")]) == 0
    printed = capsys.readouterr().out
    assert "pointing sigma 0.5 px (the hand-click default" in printed and "assumed" in printed
    assert main(["measure", "--calibration", str(tmp_path / "bare.json"), "--picks", str(tmp_path / "picks.csv"),
                 "--out", str(tmp_path / "fish.csv"), "--frame", "rig", "--pointing-sigma", "0.8"]) == 0
    assert "pointing sigma 0.8 px (given)" in capsys.readouterr().out
    row = next(csv.DictReader((tmp_path / "fish.csv").open()))
    assert "assumed" in row["sigma_notes"] and "pointing only" in row["sigma_notes"]
    assert (row["pointing_sigma_px"], row["pointing_origin"], float(row["sigma_calibration"])) == ("0.8", "given", 0)


def test_export_of_a_water_calibration_warns_on_one_line_each(tmp_path, capsys):
    source = SAMPLES / "rov_flatport" / "calibration.json"
    assert main(["calibration", "export", str(source), "--out", str(tmp_path / "stereo.yml")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert any("flat-port housing is left out" in line for line in err)
    assert all(line.startswith("usvips calibration export: warning: ") for line in err)
    assert (tmp_path / "stereo.yml").is_file()


@pytest.mark.parametrize("arguments, message", [
    (["--image-size", "1280by960"], "--image-size: expected WIDTHxHEIGHT"),
    (["--image-size", "640x480"], "mismatched image sizes"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, arguments, message):
    path = _write(tmp_path / "stereo.yml", M1=M1, D1=D1, M2=M2, D2=D2, R=R, T=T, image_width=1280,
                  image_height=960)
    assert main(["calibration", "import", path, "--out", str(tmp_path / "cal.json"), *arguments]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "cal.json").exists()


def test_rational_terms_are_refused_by_name(tmp_path, capsys):
    path = _write(tmp_path / "rational.yml", M1=M1, D1=np.array([[-0.1, 0.02, 0, 0, 0.01, 0.3, 0.1, 0.0]]), M2=M2,
                  D2=D2, R=R, T=T)
    assert main(["calibration", "import", path, "--out", str(tmp_path / "cal.json")]) == 2
    err = capsys.readouterr().err
    assert "rational model (k4=0.3, k5=0.1)" in err and err.count("\n") == 1
