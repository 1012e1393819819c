"""The measuring service: picks files grouped into objects, measured with a calibration, as table rows."""

import numpy as np
import pytest

from tests.core.calibration_scenes import FLAT, NOISE_PX, rig_at
from usvips.app.measure import MEASUREMENT_COLUMNS, measure_objects, measurement_row, picked_objects
from usvips.core.errors import DegenerateGeometryError, InputFileError
from usvips.core.stereo_calibration import StereoCalibration


def _calibration():
    rig = rig_at(0, FLAT)
    return rig, StereoCalibration.from_cameras(rig.left, rig.right, "water", NOISE_PX, station="1")


def test_fish_of_many_random_poses_measure_their_length_within_their_sigma(tmp_path):
    """Picks with a known pointing noise, stated as their pointing sigma: the normalised errors of the lengths (the
    calibration here is exact, so only the pointing counts) have a mean square near 1."""
    rig, calibration = _calibration()
    rng = np.random.default_rng(11)
    lengths, rows = {}, ["object,type,vertex,xl,yl,xr,yr,attribute"]
    while len(lengths) < 300:
        snout = np.array([rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.2), rng.uniform(-0.6, -0.1)])
        direction = rng.normal(size=3)
        length = rng.uniform(0.2, 0.5)
        ends = np.array([snout, snout + length * direction / np.linalg.norm(direction)])
        pl, pr = rig.left.project(ends), rig.right.project(ends)
        if not (pl.ok.all() and pr.ok.all()):
            continue
        name = f"fish{len(lengths)}"
        lengths[name] = length
        for v in range(2):
            xl, yl = pl.pixels[v] + rng.normal(0, NOISE_PX, 2)
            xr, yr = pr.pixels[v] + rng.normal(0, NOISE_PX, 2)
            rows.append(f"{name},length,{v},{xl},{yl},{xr},{yr},cod")
    (tmp_path / "picks.csv").write_text("\n".join(rows) + "\n")
    objects = picked_objects(tmp_path / "picks.csv")
    assert [o[0] for o in objects] == list(lengths) and all(o[1] == "length" for o in objects)
    measured = measure_objects(calibration, objects, "1", "object", pointing_sigma_px=NOISE_PX)
    z = np.array([(m.main.value - lengths[m.id]) / m.main.sigma for m in measured])
    assert 0.8 < np.mean(z**2) < 1.25
    row = measurement_row(measured[0])
    assert len(row) == len(MEASUREMENT_COLUMNS) and row[:5] == ["fish0", "length", "cod", "2", "length"]
    assert float(row[MEASUREMENT_COLUMNS.index("ray_rms_mm")]) == pytest.approx(measured[0].ray_rms_m * 1000,
                                                                                 rel=1e-6)


def test_an_object_mixing_types_is_named_with_its_file_and_line(tmp_path):
    (tmp_path / "p.csv").write_text("object,type,vertex,xl,yl,xr,yr\nf,point,0,1,2,3,4\nf,length,1,1,2,3,4\n")
    with pytest.raises(InputFileError, match=r"p\.csv.*line 2.*object 'f' mixes types"):
        picked_objects(tmp_path / "p.csv")
    # the same vertex number under two types: the types are what is wrong, not the number
    (tmp_path / "p.csv").write_text("object,type,vertex,xl,yl,xr,yr\nf,point,1,1,2,3,4\nf,length,1,1,2,3,4\n"
                                    "f,length,2,5,2,7,4\n")
    with pytest.raises(InputFileError, match=r"object 'f' mixes types: point on line 2, length on line 3"):
        picked_objects(tmp_path / "p.csv")


def test_rays_that_do_not_meet_name_the_file_and_the_object(tmp_path):
    _, calibration = _calibration()
    pixels = np.array([[10.0, 480.0, 1270.0, 480.0]])  # rays that part: the left one looks left, the right right
    with pytest.raises(DegenerateGeometryError, match="picks.csv: object 'x'"):
        measure_objects(calibration, [("x", "point", pixels, "")], where="picks.csv")
