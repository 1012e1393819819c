"""Every registered housing kind: the registry, validity, trace → back-projection, the file and scene
round trips, and phase-2 recovery of its parameters on a synthetic rig."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.core.calibration_scenes import HEIGHT, LEFT, RELATIVE, RIGHT, WIDTH, control_frame, observe, station
from usvips.core import housing as housings
from usvips.core.calibration import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.calibration.parameter_names import housing_parameter_names
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.housing import AirHousing
from usvips.core.rig import RelativeOrientation, StereoRig
from usvips.io.calibration_file import calibration_from_dict, calibration_to_dict, housing_from_dict, housing_to_dict
from usvips.io.scene import read_scene

KINDS = housings.names()
WATER = housings.water_names()


def drawn_values(cls, rng, spread: float = 0.5) -> dict[str, float]:
    """Calibration values of a kind: each parameter its default start moved by up to ``spread`` of its prior
    sigma (fixed ones at their start)."""
    values = {}
    for name in cls.calibration_names:
        base = name.rpartition("_")[0] if name.endswith(("_l", "_r")) else name
        spec = cls.spec(base)
        values[name] = spec.start + (spread * spec.sigma * rng.uniform(-1, 1) if spec.sigma else 0.0)
    return values


#: Offsets from the default starts that make a drawn housing the kind as built: System I's spheres sit
#: 1.5-3.5 cm behind the perspective centres (the thesis's design). (A sphere within a centimetre of the
#: perspective centre, where it hardly bends a ray, is where System I's phase 2 still sticks against t = 0
#: — issue 13's open rigs.)
AS_BUILT = {"dome-cover": {"c_l": 0.02, "c_r": 0.02}}


def drawn_housings(cls, rng, relative=RELATIVE, spread: float = 0.5):
    """A left and right housing of a kind on a rig, and the calibration values that build them."""
    values = drawn_values(cls, rng, spread)
    for name, offset in AS_BUILT.get(cls.kind, {}).items():
        values[name] += offset
    # the rig's relative orientation maps left-camera points into the right camera's frame
    rotation, translation = relative.rotation, -relative.rotation @ relative.base
    return (*cls.build(values, rotation, translation), values)


#: A System I-like rig (7 cm baseline, cameras nearly parallel) for the geometric round trips: behind one
#: shared cover plane the right camera of the 40 cm, 7° toed-in test rig sees its cover tilted by 8°.
NEAR_PARALLEL = RelativeOrientation(0.07, 0.001, -0.002, 0.002, -0.01, 0.003)


def test_the_registry_knows_every_kind_and_refuses_others_by_name():
    assert {"air", "flat-port", "dome-cover", "dome-port"} <= set(KINDS)
    assert "air" not in WATER and set(WATER) < set(KINDS)
    for name in KINDS:
        assert housings.kind(name).kind == name
    with pytest.raises(housings.UnknownHousingError, match="unknown housing kind 'bathyscaphe'; known: air"):
        housings.kind("bathyscaphe")
    with pytest.raises(housings.UnknownHousingError):
        housings.kind("air", among=WATER)


@pytest.mark.parametrize("name", WATER)
def test_a_kind_states_its_parameters_with_units_priors_and_bounds(name):
    cls = housings.kind(name)
    symbols = {s.symbol for s in cls.specs}
    assert len(symbols) == len(cls.specs)
    for spec in cls.specs:
        assert spec.unit in ("m", "—") and spec.meaning
        assert spec.sigma is None or spec.sigma > 0
        assert spec.lower is None or spec.start > spec.lower
    for calibration_name in cls.calibration_names:  # every estimated name has a documented symbol
        base = calibration_name.rpartition("_")[0] if calibration_name.endswith(("_l", "_r")) else calibration_name
        assert base in symbols, calibration_name
    assert housing_parameter_names(name) == list(cls.calibration_names)
    assert set(cls.start_grid) <= symbols and cls.report_note
    with pytest.raises(InvalidParameterError, match=f"is not a parameter of the {name} housing"):
        cls.spec("nonsense")


@pytest.mark.parametrize("name", WATER)
def test_physical_states_only(name):
    """A valid housing builds; each way out of the physical region is refused naming the parameter."""
    cls = housings.kind(name)
    good = cls.from_symbols()
    values = good.to_values()
    for spec in cls.specs:
        if spec.symbol not in values:
            continue
        if spec.unit == "m" and spec.lower is not None:  # a length at its bound: no glass, no radius, ...
            with pytest.raises(InvalidParameterError) as caught:
                cls.from_values(values | {spec.symbol: spec.lower})
            assert caught.value.parameter in values
        if spec.symbol.startswith("n"):
            with pytest.raises(InvalidParameterError, match=spec.symbol):
                cls.from_values(values | {spec.symbol: 0.0})
        with pytest.raises(InvalidParameterError):
            cls.from_values(values | {spec.symbol: float("nan")})
    with pytest.raises(InvalidParameterError, match="not a parameter"):
        cls.from_values(values | {"q": 1.0})
    required = [k for k in cls.field_names() if k not in ("n1", "n2", "n3")]
    with pytest.raises(InvalidParameterError, match="missing"):
        cls.from_values({k: v for k, v in values.items() if k != required[0]})


@pytest.mark.parametrize("name", KINDS)
def test_trace_and_back_projection_agree(name):
    """Pixels → rays through the housing → points 0.5-6 m along them → back-projected pixels."""
    rng = np.random.default_rng(7)
    # (at the edge of the priors a System I right cover, 1.5 cm decentred in a 5 cm sphere, defeats the
    # back-projection at the frame's corners: camera.py's solver ends in total internal reflection there)
    left, right, _ = drawn_housings(housings.kind(name), rng, NEAR_PARALLEL, spread=0.25)
    for housing in (left, right):
        camera = Camera(LEFT, Exterior(0.2, -0.1, 2.0, 0.03, -0.05, 0.1), housing, WIDTH, HEIGHT)
        pixels = np.column_stack([rng.uniform(0, WIDTH, 200), rng.uniform(0, HEIGHT, 200)])
        rays = camera.rays(pixels)
        assert rays.ok.all()
        points = rays.origins + rng.uniform(0.5, 6.0, (200, 1)) * rays.directions
        back = camera.project(points)
        assert back.ok.all()
        np.testing.assert_allclose(back.pixels, pixels, atol=1e-5)


@pytest.mark.parametrize("name", KINDS)
def test_file_and_scene_round_trips(name, tmp_path):
    cls = housings.kind(name)
    left, right, _ = drawn_housings(cls, np.random.default_rng(11))
    for housing in (left, right):
        again = housing_from_dict(name, json.loads(json.dumps(housing_to_dict(housing))))
        assert type(again) is cls and again.to_values() == housing.to_values()
    # a whole calibration file
    rig = StereoRig.from_relative(Camera(LEFT, Exterior(0, 0, 0), left, WIDTH, HEIGHT),
                                  Camera(RIGHT, Exterior(0, 0, 0), right, WIDTH, HEIGHT), RELATIVE)
    from usvips.core.stereo_calibration import StereoCalibration

    calibration = StereoCalibration(rig.left, rig.right, ("1",), (rig.left.exterior,), RELATIVE, "water", 0.3, {})
    data = json.loads(json.dumps(calibration_to_dict(calibration)))
    assert data["housing"] == name
    loaded = calibration_from_dict(data)
    assert loaded.left.housing.to_values() == left.to_values()
    assert loaded.right.housing.to_values() == right.to_values()
    # a scene
    scene = {"format": "usvips-scene", "version": 1, "name": "round", "image": {"width": 64, "height": 48},
             "left": {"f": 60, "xp": 32, "yp": 24}, "right": {"f": 60, "xp": 32, "yp": 24},
             "relative": {"bx": 0.3}, "housing": {"kind": name, "left": left.to_values(), "right": right.to_values()},
             "pairs": [{"label": "w1", "pose": {"X0": 0, "Y0": 0, "Z0": 2, "omega": 0, "phi": 0, "kappa": 0}}]}
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    read = read_scene(path)
    assert read.housing("left").to_values() == left.to_values()
    assert read.housing("right").to_values() == right.to_values()


@pytest.mark.parametrize("name", WATER)
def test_bad_housing_values_in_files_are_one_line_errors(name, tmp_path):
    cls = housings.kind(name)
    values = cls.from_symbols().to_values()
    with pytest.raises(UsvipsError, match="not a parameter of the"):
        housing_from_dict(name, values | {"zz": 1.0})
    scene = {"format": "usvips-scene", "version": 1, "name": "bad", "image": {"width": 64, "height": 48},
             "left": {"f": 60, "xp": 32, "yp": 24}, "right": {"f": 60, "xp": 32, "yp": 24},
             "relative": {"bx": 0.3},
             "housing": {"kind": name, "left": values, "right": values | {"zz": 1.0}},
             "pairs": [{"label": "w1", "pose": {"X0": 0, "Y0": 0, "Z0": 2, "omega": 0, "phi": 0, "kappa": 0}}]}
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    with pytest.raises(UsvipsError, match=r"housing\.right: parameter zz: is not a parameter") as caught:
        read_scene(path)
    assert "\n" not in str(caught.value)


@pytest.fixture(scope="module")
def phase_one():
    control = control_frame(48)
    rig = StereoRig.from_relative(Camera(LEFT, station(0), AirHousing(), WIDTH, HEIGHT),
                                  Camera(RIGHT, station(0), AirHousing(), WIDTH, HEIGHT), NEAR_PARALLEL)
    pair = observe(rig, control.xyz, control.ids, "air1", seed=5, noise=0.1)
    return control, calibrate_air(control, pair.observations, CalibrationOptions(sigma_px=0.1)).calibration


@pytest.mark.slow
@pytest.mark.parametrize("name", WATER)
def test_phase_two_recovers_the_housing_on_a_synthetic_rig(name, phase_one):
    """Phase 2 from noisy pixels of a drawn housing: every estimated housing parameter within 3.5 of its
    sigmas of the truth, and the mean squared normalised error of them all below 3 (a handful of them)."""
    control, base = phase_one
    cls = housings.kind(name)
    rng = np.random.default_rng(21)
    left, right, truth = drawn_housings(cls, rng, NEAR_PARALLEL)
    rig = StereoRig.from_relative(Camera(LEFT, station(1), left, WIDTH, HEIGHT),
                                  Camera(RIGHT, station(1), right, WIDTH, HEIGHT), NEAR_PARALLEL)
    pair = observe(rig, control.xyz, control.ids, "water1", seed=6, noise=0.1)
    result = calibrate_water(base, name, control, pair.observations, CalibrationOptions(sigma_px=0.1))
    assert result.adjustment.converged, result.report.reason
    normalised = []
    for parameter in cls.calibration_names:
        estimate = result.calibration.parameters[parameter]
        if estimate.status == "fixed":
            assert estimate.value == pytest.approx(truth[parameter])
            continue
        z = (estimate.value - truth[parameter]) / estimate.sigma
        assert abs(z) < 3.5, f"{parameter}: {estimate.value:.6g} ± {estimate.sigma:.2g}, truth {truth[parameter]:.6g}"
        normalised.append(z * z)
    assert np.mean(normalised) < 3.0
