"""Monte Carlo over rigs: both phases on many random rigs of each housing, checked on independent points.

Each rig is drawn from ranges (baseline, toe-in, cover or port geometry, tilt, indices, distortion,
pointing noise 0.2-0.5 px), calibrated in air and in water from noisy pixels of a control frame, and then
measures check points, lengths and triangle areas it never saw. The errors against the truth, normalised
by the covariance the calibration reports (pointing + the calibration's own, with the correlation a common
calibration puts between points), must have a mean square near 1, and the check points' RMS must be what
that covariance predicts. System I rigs follow the thesis's design (``tank_system1``); System II rigs
the ``rov_flatport`` kind, with the glass thickness and index known (fixed) as a careful user would.
"""

from __future__ import annotations

import numpy as np
import pytest

from usvips.core.calibration import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.calibration.uncertainty import joint_covariance
from usvips.core.camera import Camera, Exterior
from usvips.core.housing import AirHousing, DomeCoverHousing, FlatPortHousing, shared_plane_in_camera
from usvips.core.interior import Interior
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.rig import RelativeOrientation, StereoRig, relative_orientation

RIGS = 20


def _observe(rig: StereoRig, xyz: np.ndarray, label: str, rng, noise: float):
    left, right = rig.left.project(xyz), rig.right.project(xyz)
    idx = np.flatnonzero(left.ok & right.ok)
    return StereoObservations(tuple(str(i + 1) for i in idx), left.pixels[idx] + rng.normal(0, noise, (idx.size, 2)),
                              right.pixels[idx] + rng.normal(0, noise, (idx.size, 2)), (label,) * idx.size), idx


def _rig(left_interior, right_interior, relative, pose, housings, size):
    left = Camera(left_interior, pose, housings[0] if housings else AirHousing(), *size)
    right = Camera(right_interior, pose, AirHousing(), *size)
    rig = StereoRig.from_relative(left, right, relative)
    if housings:
        right_housing = housings[1](relative_orientation(rig.left.exterior, rig.right.exterior))
        rig = StereoRig(rig.left, Camera(right_interior, rig.right.exterior, right_housing, *size))
    return rig


def _system_one(rng):
    """The thesis's System I: 568 × 488 px, f ≈ 545 px, 6-9 cm baseline, one cover plane 2-6 cm of glass
    beyond concave spheres of 8-10 cm radius centred 1.5-3.5 cm behind each perspective centre; the
    thesis's 1.44 m frame 2.3-2.5 m away (targets on two depths)."""
    def interior():
        return Interior(f=rng.uniform(520, 570), xp=284 + rng.normal(0, 6), yp=244 + rng.normal(0, 6),
                        sy=rng.uniform(0.86, 0.88), k1=rng.uniform(-0.14, -0.08))
    relative = RelativeOrientation(rng.uniform(0.06, 0.09), rng.normal(0, 0.002), rng.normal(0, 0.002),
                                   rng.normal(0, 0.005), rng.uniform(-0.03, 0.0), rng.normal(0, 0.005))
    n2, n3 = rng.uniform(1.5, 1.7), rng.uniform(1.33, 1.345)
    a, b, c, r = rng.normal(0, 0.002), rng.normal(0, 0.002), rng.uniform(0.015, 0.035), rng.uniform(0.08, 0.1)
    d, e = rng.normal(0, 0.008, 2)
    g = rng.uniform(0.02, 0.06) + r * np.sqrt(d * d + e * e + 1) - (d * a + e * b + c)
    left = DomeCoverHousing(a, b, c, r, d, e, g, n2, n3)
    sphere = rng.normal(0, 0.002), rng.normal(0, 0.002), rng.uniform(0.015, 0.035), rng.uniform(0.08, 0.1)

    def right(rel):
        plane = shared_plane_in_camera(d, e, g, rel.rotation, -rel.rotation @ rel.base)
        return DomeCoverHousing(*sphere, *plane, n2, n3)

    grid = np.linspace(0, 1.44, 5)
    xy = np.array([(x, y) for x in grid for y in grid])
    z = -np.where(np.arange(len(xy)) % 3 == 0, rng.uniform(0.0, 0.7, len(xy)), 0.0)
    control = np.column_stack([100 + xy, -100 + z])

    def pose(z0):
        return Exterior(100.7 + rng.normal(0, 0.03), 100.7 + rng.normal(0, 0.03), z0 + rng.normal(0, 0.1),
                        *rng.normal(0, 0.02, 3))

    check = np.column_stack([rng.uniform(100.1, 101.3, 30), rng.uniform(100.1, 101.3, 30),
                             rng.uniform(-100.7, -99.8, 30)])
    return dict(kind="dome-cover", interiors=(interior(), interior()), relative=relative, housings=(left, right),
                control=control, air=pose(-97.6), water=pose(-97.7), check=check, size=(568, 488), options={})


def _system_two(rng):
    """System II (``rov_flatport`` kind): 1280 × 960 px, f ≈ 1100 px, 30-50 cm baseline, a flat port per
    camera 4-9 cm ahead, tilted up to 1.5°, 16 mm of glass of known index; a 1.4 m frame 2.4-2.9 m away."""
    def interior():
        return Interior(f=rng.uniform(1050, 1150), xp=640 + rng.normal(0, 10), yp=480 + rng.normal(0, 10),
                        sy=1.0 + rng.normal(0, 0.01), k1=rng.uniform(-0.12, -0.05))
    relative = RelativeOrientation(rng.uniform(0.3, 0.5), rng.normal(0, 0.005), rng.normal(0, 0.01),
                                   rng.normal(0, 0.005), rng.uniform(-0.15, -0.08), rng.normal(0, 0.005))
    t, n2, n3 = 0.016, 1.65, rng.uniform(1.33, 1.345)
    left = FlatPortHousing(*rng.normal(0, 0.012, 2), rng.uniform(0.04, 0.09), t, n2, n3)
    port = (*rng.normal(0, 0.012, 2), rng.uniform(0.04, 0.09))
    control = np.column_stack([rng.uniform(0, 1.4, 48), rng.uniform(0, 1.4, 48), rng.uniform(-0.7, 0.0, 48)])

    def pose(z0):
        return Exterior(0.5 + rng.normal(0, 0.05), 0.7 + rng.normal(0, 0.05), z0, *rng.normal(0, 0.03, 3))

    check = np.column_stack([rng.uniform(0.1, 1.3, 30), rng.uniform(0.1, 1.3, 30), rng.uniform(-0.7, 0.2, 30)])
    return dict(kind="flat-port", interiors=(interior(), interior()), relative=relative,
                housings=(left, lambda rel: FlatPortHousing(*port, t, n2, n3)), control=control,
                air=pose(rng.uniform(2.4, 2.9)), water=pose(rng.uniform(2.4, 2.9)), check=check, size=(1280, 960),
                options={"fix_values": {"t": t, "n2": n2}})


def _area(p: np.ndarray) -> tuple[float, np.ndarray]:
    """A triangle's area and its gradient with respect to its 9 coordinates."""
    a, b, c = p
    normal = np.cross(b - a, c - a)
    area = 0.5 * np.linalg.norm(normal)
    h = 1e-6
    grad = np.zeros(9)
    for k in range(9):
        q = p.reshape(-1).copy()
        q[k] += h
        qa, qb, qc = q.reshape(3, 3)
        grad[k] = (0.5 * np.linalg.norm(np.cross(qb - qa, qc - qa)) - area) / h
    return area, grad


def _one_rig(draw, seed):
    rng = np.random.default_rng(seed)
    scene = draw(rng)
    noise = rng.uniform(0.2, 0.5)
    ids = tuple(str(i + 1) for i in range(len(scene["control"])))
    control = ControlPoints(ids, scene["control"])
    interiors, relative, size = scene["interiors"], scene["relative"], scene["size"]
    air_rig = _rig(*interiors, relative, scene["air"], None, size)
    water_rig = _rig(*interiors, relative, scene["water"], scene["housings"], size)
    air_obs, _ = _observe(air_rig, scene["control"], "air1", rng, noise)
    water_obs, _ = _observe(water_rig, scene["control"], "water1", rng, noise)
    options = CalibrationOptions(sigma_px=0.5)  # the default a-priori sigma, not the true noise
    air = calibrate_air(control, air_obs, options)
    water = calibrate_water(air.calibration, scene["kind"], control, water_obs,
                            CalibrationOptions(sigma_px=0.5, **scene["options"]))
    check_obs, idx = _observe(water_rig, scene["check"], "water1", rng, noise)
    result, covariance = joint_covariance(water.calibration, check_obs.left, check_obs.right)
    truth = scene["check"][idx]
    ok = np.flatnonzero(result.ok)
    errors = result.points - truth
    blocks = [covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3] for i in range(len(truth))]
    points = [float(errors[i] @ np.linalg.solve(blocks[i], errors[i])) / 3 for i in ok]
    lengths, areas = [], []
    for i, j in zip(ok[0::2], ok[1::2], strict=False):
        d_est, d_true = result.points[i] - result.points[j], truth[i] - truth[j]
        unit = d_est / np.linalg.norm(d_est)
        grad = np.concatenate([unit, -unit])
        index = np.r_[3 * i:3 * i + 3, 3 * j:3 * j + 3]
        variance = grad @ covariance[np.ix_(index, index)] @ grad
        lengths.append((np.linalg.norm(d_est) - np.linalg.norm(d_true)) ** 2 / variance)
    for i, j, k in zip(ok[0::3], ok[1::3], ok[2::3], strict=False):
        area, grad = _area(result.points[[i, j, k]])
        index = np.r_[3 * i:3 * i + 3, 3 * j:3 * j + 3, 3 * k:3 * k + 3]
        variance = grad @ covariance[np.ix_(index, index)] @ grad
        areas.append((area - _area(truth[[i, j, k]])[0]) ** 2 / variance)
    predicted = np.mean([np.diag(blocks[i]) for i in ok], axis=0)
    return dict(report=water.report, noise=noise, points=points, lengths=lengths, areas=areas,
                squared=np.mean(errors[ok] ** 2, axis=0), predicted=predicted)


#: Share of rigs that must calibrate cleanly: all (issue 13). Phase 2 reruns from the next-best distinct
#: starts when a run ends on a bound, unconverged or with several tau rejections; before that 3 of the 20
#: System I draws did not calibrate cleanly.
CLEAN_SHARE = {"dome-cover": 1.0, "flat-port": 1.0}


def _clean(run) -> bool:
    report = run["report"]
    bounded = [b.parameter for b in report.on_bound]
    honest_noise = 0.75 < report.sigma0_px / run["noise"] < 1.3
    return report.converged and all(name.startswith("g_") for name in bounded) and honest_noise


@pytest.mark.slow
@pytest.mark.parametrize("draw", [_system_one, _system_two], ids=["dome-cover", "flat-port"])
def test_calibrations_over_many_rigs_converge_and_their_sigmas_are_honest(draw):
    runs = [_one_rig(draw, 1000 + k) for k in range(RIGS)]
    kind = runs[0]["report"].housing
    clean = [run for run in runs if _clean(run)]
    assert len(clean) >= CLEAN_SHARE[kind] * RIGS, f"{RIGS - len(clean)} of {RIGS} rigs did not calibrate cleanly"
    for k, run in enumerate(runs):
        report = run["report"]
        if not report.converged:
            assert any("NOT converged" in note for note in report.notes), f"rig {k}"
        for bound in report.on_bound:
            # a flat port's distance g, barely separable from the focal length under known glass, may end
            # against g = 0; System I's glass thicknesses should not — either way the report must say so
            assert any(f"{bound.parameter} ends on its lower bound" in note for note in report.notes), f"rig {k}"
    msne = {figure: float(np.mean(np.concatenate([run[figure] for run in clean])))
            for figure in ("points", "lengths", "areas")}
    rms = np.sqrt(np.mean([run["squared"] for run in clean], axis=0))
    predicted = np.sqrt(np.mean([run["predicted"] for run in clean], axis=0))
    print(f"{kind}: {len(clean)}/{RIGS} clean; MSNE {msne}; check RMS / predicted {rms / predicted}")
    for figure, value in msne.items():
        assert 0.7 <= value <= 1.5, f"{figure}: mean squared normalised error {value:.2f}"
    np.testing.assert_allclose(rms, predicted, rtol=0.2)
