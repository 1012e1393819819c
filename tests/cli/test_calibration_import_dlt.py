"""``usvips calibration import --format dlt`` (issue 33, item 9): a DLTdv/Argus coefficient file becomes a
calibration ``intersect`` uses; the skew's effect printed per band of rows; bad input one line, exit 2."""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.test_dlt_camera import coefficients_of, dlt_pixels, points_in_view, random_camera
from tests.io.test_dlt_coefficients import HEIGHT, _as_tool
from usvips.cli import main
from usvips.io.calibration_file import load_calibration


@pytest.fixture()
def argus(tmp_path):
    rng = np.random.default_rng(11)
    cameras = [random_camera(rng)[:2] for _ in range(2)]
    cameras[1][0][0, 1] = 3.0  # the right camera's pixel grid is sheared
    ours = [coefficients_of(k, pose) for k, pose in cameras]
    path = tmp_path / "wand-dlt-coefs.csv"
    tool = np.array([_as_tool(c, "bottom-left", True) for c in ours]).T
    path.write_text("\n".join(",".join(f"{v:.17g}" for v in row) for row in tool) + "\n")
    return path, ours, points_in_view(cameras[0][1], rng)


def test_an_argus_file_imports_and_reproduces_the_cameras(argus, tmp_path, capsys):
    path, ours, points = argus
    out = tmp_path / "cal.json"
    assert main(["calibration", "import", "--format", "dlt", str(path), "--origin", "bottom-left", "--one-based",
                 "--image-size", f"1280x{HEIGHT}", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "sigma0 0.5 px (assumed" in printed
    assert "right camera: skew 3 px dropped" in printed and "left camera: skew" not in printed
    rig = load_calibration(out).rig("dlt")
    left = rig.left.project(points).pixels
    assert np.abs(left - dlt_pixels(ours[0], points)).max() < 1e-6


@pytest.mark.parametrize("extra, message", [
    (["--origin", "bottom-left"], "--origin: bottom-left needs --image-size"),
    (["--cameras", "1", "5"], "--cameras: two different camera numbers from 1 to 2"),
    (["--sigma0", "0"], "--sigma0: must be > 0"),
])
def test_bad_choices_are_one_line(argus, tmp_path, capsys, extra, message):
    out = tmp_path / "cal.json"
    assert main(["calibration", "import", "--format", "dlt", str(argus[0]), *extra, "--out", str(out)]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and message in error, error
    assert not out.exists()


def test_a_bad_file_names_its_line(tmp_path, capsys):
    path = tmp_path / "dlt.csv"
    path.write_text("1,2\n3,oops\n")
    assert main(["calibration", "import", "--format", "dlt", str(path), "--out", str(tmp_path / "c.json")]) == 2
    assert "line 2: 'oops' is not a number" in capsys.readouterr().err
