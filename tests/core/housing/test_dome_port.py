"""The hemispherical dome port: its geometry (no refraction at the centre, an axial camera when
decentred, physical states only) and its calibration over many synthetic rigs (the decentring recovered
within its sigma, check points with a mean squared normalised error near 1)."""

from __future__ import annotations

import numpy as np
import pytest

from usvips.core.calibration import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.calibration.uncertainty import joint_covariance
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InvalidParameterError
from usvips.core.housing import AirHousing, DomePortHousing
from usvips.core.interior import Interior
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.rig import RelativeOrientation, StereoRig

INTERIOR = Interior(f=900.0, xp=640.0, yp=480.0, sy=1.0, k1=-0.08)
DECENTRING = ("dx", "dy", "dz")


def test_a_camera_at_the_dome_centre_sees_no_refraction():
    pixels = np.column_stack([np.linspace(0, 1279, 50), np.linspace(959, 0, 50)])
    dome = Camera(INTERIOR, Exterior(0, 0, 0), DomePortHousing(0, 0, 0, 0.05, 0.01, 1.49, 1.34), 1280, 960)
    air = Camera(INTERIOR, Exterior(0, 0, 0), AirHousing(), 1280, 960)
    np.testing.assert_allclose(dome.rays(pixels).directions, air.rays(pixels).directions, atol=1e-12)
    points = np.array([[0.3, -0.2, -2.0], [-1.0, 0.5, -4.0]])
    np.testing.assert_allclose(dome.project(points).pixels, air.project(points).pixels, atol=1e-6)


def test_a_decentred_dome_is_an_axial_camera_that_bends_rays():
    housing = DomePortHousing(0.003, -0.002, 0.004, 0.05, 0.01, 1.49, 1.34)
    axis = housing.axis
    assert axis is not None  # the axis joins the perspective centre and the dome centre
    np.testing.assert_allclose(np.cross(axis, housing.center), 0.0, atol=1e-15)
    dome = Camera(INTERIOR, Exterior(0, 0, 0), housing, 1280, 960)
    air = Camera(INTERIOR, Exterior(0, 0, 0), AirHousing(), 1280, 960)
    point = np.array([[0.8, 0.5, -1.5]])
    shift = np.linalg.norm(dome.project(point).pixels - air.project(point).pixels)
    assert shift > 0.5  # a few millimetres of decentring move a near point by pixels


@pytest.mark.parametrize(("values", "parameter"), [
    (dict(dx=0.04, dy=0.03, dz=0.0, r=0.05, t=0.01), "dx"),  # the perspective centre outside the dome
    (dict(dx=0.0, dy=0.0, dz=0.0, r=0.0, t=0.01), "r"),
    (dict(dx=0.0, dy=0.0, dz=0.0, r=0.05, t=-0.001), "t"),
    (dict(dx=0.0, dy=float("inf"), dz=0.0, r=0.05, t=0.01), "dy"),
    (dict(dx=0.0, dy=0.0, dz=0.0, r=0.05, t=0.01, n2=0.0), "n2"),
])
def test_unphysical_domes_are_refused_by_name(values, parameter):
    with pytest.raises(InvalidParameterError) as caught:
        DomePortHousing(**values)
    assert caught.value.parameter == parameter


def _observe(rig, xyz, label, rng, noise):
    left, right = rig.left.project(xyz), rig.right.project(xyz)
    idx = np.flatnonzero(left.ok & right.ok)
    return StereoObservations(tuple(str(i + 1) for i in idx), left.pixels[idx] + rng.normal(0, noise, (idx.size, 2)),
                              right.pixels[idx] + rng.normal(0, noise, (idx.size, 2)), (label,) * idx.size), idx


def _one_rig(seed: int) -> dict:
    """A rig of two dome-port cameras drawn from ranges, calibrated in air and in water (the dome's radius,
    thickness and glass index known from the manufacturer), then measuring independent check points."""
    rng = np.random.default_rng(seed)
    noise = rng.uniform(0.2, 0.5)

    def interior():
        return Interior(f=rng.uniform(850, 950), xp=640 + rng.normal(0, 8), yp=480 + rng.normal(0, 8),
                        sy=1.0 + rng.normal(0, 0.005), k1=rng.uniform(-0.12, -0.04))

    r, t, n2, n3 = rng.uniform(0.04, 0.1), rng.uniform(0.005, 0.015), rng.uniform(1.47, 1.52), rng.uniform(1.33, 1.345)
    domes = [DomePortHousing(*rng.normal(0, 0.002, 2), rng.normal(0, 0.004), r, t, n2, n3) for _ in range(2)]
    relative = RelativeOrientation(rng.uniform(0.3, 0.5), rng.normal(0, 0.005), rng.normal(0, 0.01),
                                   rng.normal(0, 0.005), rng.uniform(-0.15, -0.08), rng.normal(0, 0.005))
    interiors = interior(), interior()
    control_xyz = np.column_stack([rng.uniform(0, 1.4, 48), rng.uniform(0, 1.4, 48), rng.uniform(-0.7, 0.0, 48)])
    control = ControlPoints(tuple(str(i + 1) for i in range(48)), control_xyz)

    def rig(housings, z0):
        pose = Exterior(0.5 + rng.normal(0, 0.05), 0.7 + rng.normal(0, 0.05), z0, *rng.normal(0, 0.03, 3))
        return StereoRig.from_relative(Camera(interiors[0], pose, housings[0], 1280, 960),
                                       Camera(interiors[1], pose, housings[1], 1280, 960), relative)

    air_obs, _ = _observe(rig((AirHousing(), AirHousing()), rng.uniform(2.4, 2.9)), control_xyz, "air1", rng, noise)
    water_rig = rig(domes, rng.uniform(2.4, 2.9))
    water_obs, _ = _observe(water_rig, control_xyz, "water1", rng, noise)
    air = calibrate_air(control, air_obs, CalibrationOptions(sigma_px=0.5))
    known = CalibrationOptions(sigma_px=0.5, fix_values={"r": r, "t": t, "n2": n2})
    water = calibrate_water(air.calibration, DomePortHousing.kind, control, water_obs, known)
    decentring = []
    for side, dome in zip("lr", domes, strict=True):
        for name in DECENTRING:
            estimate = water.calibration.parameters[f"{name}_{side}"]
            decentring.append((estimate.value - getattr(dome, name)) / estimate.sigma)
    check = np.column_stack([rng.uniform(0.1, 1.3, 30), rng.uniform(0.1, 1.3, 30), rng.uniform(-0.7, 0.2, 30)])
    check_obs, idx = _observe(water_rig, check, "water1", rng, noise)
    result, covariance = joint_covariance(water.calibration, check_obs.left, check_obs.right)
    errors = result.points - check[idx]
    points = [float(errors[i] @ np.linalg.solve(covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3], errors[i])) / 3
              for i in np.flatnonzero(result.ok)]
    return dict(report=water.report, noise=noise, decentring=np.array(decentring), points=points)


RIGS = 10


@pytest.mark.slow
def test_a_decentred_dome_port_is_recovered_over_many_rigs():
    runs = [_one_rig(2000 + k) for k in range(RIGS)]
    for k, run in enumerate(runs):
        report = run["report"]
        assert report.converged, f"rig {k}: {report.reason}"
        assert not report.on_bound, f"rig {k}: {report.on_bound}"
        assert 0.7 < report.sigma0_px / run["noise"] < 1.3, f"rig {k}: sigma0 {report.sigma0_px:.3f} px"
        assert np.all(np.abs(run["decentring"]) < 3.5), f"rig {k}: decentring z {run['decentring']}"
    decentring = np.mean(np.concatenate([run["decentring"] for run in runs]) ** 2)
    points = np.mean(np.concatenate([run["points"] for run in runs]))
    print(f"dome port: MSNE decentring {decentring:.2f}, check points {points:.2f}")
    assert 0.4 <= decentring <= 1.8, f"decentring: mean squared normalised error {decentring:.2f}"
    assert 0.7 <= points <= 1.5, f"check points: mean squared normalised error {points:.2f}"
