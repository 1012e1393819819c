"""Many objects' figures at once (``project_figures.evaluate_many``) are each exactly what the one figure
path (``evaluate``) gives — the same figures, sigmas, breakdowns and labels, or the same error — over a
survey of random fish of hand clicks, estimated and model sigmas, objects measured on several instants,
objects without a calibration and objects whose rays no longer meet."""

import dataclasses

import numpy as np
import pytest

from usvips.app.project_figures import evaluate, evaluate_many, measurement_input
from usvips.bench import scaling
from usvips.core.errors import UsvipsError
from usvips.core.measurements import QualityRules
from usvips.io.calibration_file import calibration_to_dict, load_calibration
from usvips.store import Project
from usvips.store.project import Vertex

MODEL = "keypoint (snout, model fish sha256:0123456789ab, right matched to left)"


def _survey(path, rng, count: int) -> None:
    calibration = load_calibration(scaling.CALIBRATION)
    rig = calibration.rig(0, "rig")
    with Project.create(path) as project:
        project.add_pair("dive")
        calibration_id = project.add_calibration("cal", calibration_to_dict(calibration), ("dive",))
        ids = []
        for n in range(count):
            ray = rig.left.rays(rng.uniform([150, 150], [1130, 810], (2, 2)))
            ends = ray.origins + rng.uniform(1.5, 4.0, (2, 1)) * ray.directions
            left, right = rig.left.project(ends).pixels, rig.right.project(ends).pixels
            right = right + rng.normal(0, 0.4, right.shape)
            kind = n % 5
            extra = ({} if kind == 0 else {"pointing_px": (0.8, 1.1), "pointing_origin": "estimated"} if kind == 1
                     else {"source": MODEL, "pointing_px": (1.2, 1.6), "pointing_origin": "estimated"} if kind == 2
                     else {})
            if kind == 3:  # rays that cannot meet: the right point far above its epipolar line
                right = right + np.array([0.0, 300.0])
            vertices = [Vertex(*map(float, left[i]), *map(float, right[i]), tuple(map(float, ends[i])),
                               np.eye(3) * 1e-6, None if kind == 4 else calibration_id, "dive", **extra)
                        for i in range(2)]
            ids.append(project.add_object("length", vertices, f"fish {n}", "a note"))
        for whole, instant in zip(ids[:6:2], ids[1:6:2], strict=True):  # three objects over two instants
            project.add_instant(whole, instant)


def _same(a, b) -> None:
    if isinstance(a, UsvipsError) or isinstance(b, UsvipsError):
        assert type(a) is type(b) and str(a) == str(b)
        return
    for field in dataclasses.fields(a):
        x, y = getattr(a, field.name), getattr(b, field.name)
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            x, y = np.asarray(x, float), np.asarray(y, float)
            scale = float(np.nanmax(np.abs(y))) if y.size and np.any(np.isfinite(y)) else 0.0
            np.testing.assert_allclose(x, y, rtol=1e-9, atol=1e-9 * scale, err_msg=field.name)
        elif field.name == "figures":
            assert [f.name for f in x] == [f.name for f in y]
            for f, g in zip(x, y, strict=True):
                for name in ("value", "sigma", "sigma_pointing", "sigma_calibration"):
                    u, v = getattr(f, name), getattr(g, name)
                    assert (u is None and v is None) or u == pytest.approx(v, rel=1e-9, abs=1e-15), name
        elif field.name == "combined":
            assert len(x) == len(y)
        elif isinstance(x, float) or isinstance(y, float):
            assert (x is None and y is None) or x == pytest.approx(y, rel=1e-9), field.name
        else:
            assert x == y, field.name


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_many_objects_at_once_are_each_what_the_one_figure_path_gives(tmp_path, seed):
    rng = np.random.default_rng(seed)
    path = tmp_path / "survey.usvips"
    _survey(path, rng, 40)
    rules = QualityRules(max_ray_rms_m=0.004) if seed == 2 else None
    with Project.open(path, read_only=True) as project:
        cache: dict = {}
        sources = [measurement_input(project, stored, cache) for stored in project.objects()]
    one = []
    for source in sources:
        try:
            one.append(evaluate(source, rules))
        except UsvipsError as error:
            one.append(error)
    many = evaluate_many(sources, rules)
    assert len(many) == len(one) == 40
    assert sum(isinstance(m, UsvipsError) for m in many) >= 1  # some fail, by the one path's words
    assert any(not isinstance(m, UsvipsError) and m.combined for m in many)
    for a, b in zip(one, many, strict=True):
        _same(a, b)
