import numpy as np
import pytest

from tests.core.scenes import HOUSINGS, frame_grid, make_camera
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InvalidParameterError
from usvips.core.housing import (
    AirHousing,
    DomeCoverHousing,
    DomePortHousing,
    FlatPortHousing,
    GeneralHousing,
    dome_cover_from_object_space,
    flat_port_from_object_space,
)
from usvips.core.interior import Interior
from usvips.core.rays import RayStatus
from usvips.core.surfaces import Plane, Sphere


def _same_indices(housing):
    if isinstance(housing, DomeCoverHousing):
        return DomeCoverHousing(housing.a, housing.b, housing.c, housing.r, housing.d, housing.e, housing.g,
                                n2=1.0, n3=1.0)
    if isinstance(housing, FlatPortHousing):
        return FlatPortHousing(housing.d, housing.e, housing.g, housing.t, n2=1.0, n3=1.0)
    return GeneralHousing(housing.surfaces, (1.0,) * len(housing.indices))


@pytest.mark.parametrize("name", sorted(HOUSINGS))
def test_trace_then_back_project_returns_to_the_pixel(name):
    camera = make_camera(HOUSINGS[name])
    pixels = frame_grid(40)
    rays = camera.rays(pixels).require_ok()
    for depth in (0.3, 1.0, 4.0, 20.0):
        points = rays.origins + depth * rays.directions
        projection = camera.project(points)
        assert projection.ok.all(), name
        assert np.max(np.abs(projection.pixels - pixels)) < 1e-6


@pytest.mark.parametrize("name", sorted(set(HOUSINGS) - {"air"}))
def test_equal_indices_reduce_every_housing_to_the_pinhole(name):
    pinhole = make_camera(AirHousing())
    camera = make_camera(_same_indices(HOUSINGS[name]))
    pixels = frame_grid(80)
    a, b = pinhole.rays(pixels), camera.rays(pixels)
    np.testing.assert_allclose(b.directions, a.directions, atol=1e-15)
    # the traced origin lies on the pinhole ray
    offset = b.origins - a.origins
    perpendicular = offset - np.einsum("ij,ij->i", offset, a.directions)[:, None] * a.directions
    assert np.max(np.linalg.norm(perpendicular, axis=1)) < 1e-15 * 10
    points = a.origins + 2.5 * a.directions
    np.testing.assert_allclose(camera.project(points).pixels, pinhole.project(points).pixels, atol=1e-9)


@pytest.mark.parametrize("name", sorted(set(HOUSINGS) - {"air"}))
def test_refraction_really_bends_the_rays(name):
    pixels = frame_grid(160)
    a = make_camera(AirHousing()).rays(pixels)
    b = make_camera(HOUSINGS[name]).rays(pixels)
    angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", a.directions, b.directions), -1, 1)))
    assert angle.max() > 2.0


def test_flat_port_matches_the_closed_form_of_parallel_planes():
    # a ray at angle θ in air leaves a flat port at sin θw = sin θ / n3 whatever the glass
    housing = FlatPortHousing(0.0, 0.0, 0.05, 0.02, 1.7, 1.33)
    theta = np.radians([0.0, 10.0, 25.0, 40.0])
    directions = np.column_stack([np.sin(theta), np.zeros(4), -np.cos(theta)])
    bundle = housing.trace(np.zeros_like(directions), directions)
    sin_water = np.hypot(bundle.directions[:, 0], bundle.directions[:, 1])
    np.testing.assert_allclose(sin_water, np.sin(theta) / 1.33, atol=1e-15)
    lateral = 0.05 * np.tan(theta) + 0.02 * np.tan(np.arcsin(np.sin(theta) / 1.7))
    np.testing.assert_allclose(bundle.origins[:, 0], lateral, atol=1e-15)
    np.testing.assert_allclose(bundle.origins[:, 2], -0.07, atol=1e-15)


def test_points_behind_the_camera_or_inside_the_housing_are_reported():
    camera = make_camera(HOUSINGS["flat-port"], exterior=Exterior(0, 0, 0))
    points = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -0.03], [0.1, 0.1, -2.0]])
    projection = camera.project(points)
    assert projection.status[0] == RayStatus.BEHIND_CAMERA
    assert projection.status[1] == RayStatus.BEHIND_CAMERA   # between lens and port: not in the water
    assert projection.status[2] == RayStatus.OK
    assert np.all(np.isfinite(projection.pixels))


def test_points_outside_the_frame_are_reported():
    camera = make_camera(HOUSINGS["dome-cover"], exterior=Exterior(0, 0, 0))
    projection = camera.project(np.array([[0.8, 0.0, -1.0], [0.0, 0.0, -1.0]]))
    assert list(projection.status) == [RayStatus.OUTSIDE_FRAME, RayStatus.OK]


def test_total_internal_reflection_and_missed_surfaces_have_a_status_not_nan():
    # a camera in water looking out into air through a flat window: steep rays reflect totally
    wide = Interior(f=300.0, xp=640.0, yp=480.0)
    housing = GeneralHousing((Plane.from_coefficients(0, 0, 0.05),), (1.33, 1.0))
    camera = Camera(wide, Exterior(0, 0, 0), housing)
    bundle = camera.rays(np.array([[640.0, 480.0], [1279.0, 959.0]]))
    assert list(bundle.status) == [RayStatus.OK, RayStatus.TOTAL_INTERNAL_REFLECTION]
    assert bundle.failed_surface[1] == 0
    assert np.all(np.isfinite(bundle.origins)) and np.all(np.isfinite(bundle.directions))
    # a strongly tilted cover plane that rays on one side never reach
    tilted = GeneralHousing((Plane.from_coefficients(-3.0, 0, 0.05),), (1.0, 1.33))
    bundle = Camera(wide, Exterior(0, 0, 0), tilted).rays(np.array([[640.0, 480.0], [0.0, 480.0]]))
    assert list(bundle.status) == [RayStatus.OK, RayStatus.MISSED_SURFACE]
    with pytest.raises(Exception, match="misses a cover surface"):
        bundle.require_ok()


def test_object_space_housing_parameters_convert_to_the_camera_frame():
    exterior = Exterior(100.65, 100.61, -98.24, 0.003, -0.034, -0.033)
    a, b, c, r = 100.6451, 100.6069, -98.2102, 0.0885
    d, e, g = 0.001, -0.002, 98.4 - 0.001 * 100.65 + 0.002 * 100.61
    housing = dome_cover_from_object_space(a, b, c, r, d, e, g, 1.6, 1.34, exterior.rotation, exterior.position)
    # the same surfaces held in object space trace the same object-space rays
    sphere = Sphere(np.array([a, b, c]), r)
    plane = Plane.from_coefficients(d, e, g)
    object_housing = GeneralHousing((sphere, plane), (1.0, 1.6, 1.34))
    camera = Camera(Interior(570.0, 284.0, 244.0), exterior, housing)
    pixels = np.array([[10.0, 20.0], [284.0, 244.0], [500.0, 400.0]])
    rays = camera.rays(pixels).require_ok()
    start = camera.with_exterior(exterior)
    local = Camera(start.interior, exterior, AirHousing()).rays(pixels)
    traced = object_housing.trace(local.origins, local.directions).require_ok()
    np.testing.assert_allclose(rays.directions, traced.directions, atol=1e-12)
    np.testing.assert_allclose(rays.origins, traced.origins, atol=1e-12)
    # the 1997 paper's System II: camera at Z0 = -97.79 looking down, port plane Z = -97.87
    level = Exterior(100.39, 100.67, -97.79)
    port = flat_port_from_object_space(0.0, 0.0, 97.87, 0.016, 1.65, 1.34, level.rotation, level.position)
    assert (port.d, port.e) == pytest.approx((0.0, 0.0), abs=1e-12)
    assert port.g == pytest.approx(0.08, abs=1e-9)


@pytest.mark.parametrize("build, parameter", [
    (lambda: DomeCoverHousing(0, 0, 0, -0.1, 0, 0, 0.1), "parameter r"),
    (lambda: DomeCoverHousing(0, 0, 0, 0.1, 0, 0, 0.1, n2=0.0), "parameter n2"),
    (lambda: DomeCoverHousing(0, 0, 0.2, 0.1, 0, 0, 0.1), "parameter r"),
    (lambda: FlatPortHousing(0, 0, 0.1, 0.0, 1.5, 1.33), "parameter t"),
    (lambda: FlatPortHousing(0, 0, -0.1, 0.01, 1.5, 1.33), "parameter g"),
    (lambda: FlatPortHousing(0, 0, 0.1, 0.01, 1.5, -1.0), "parameter n3"),
    (lambda: Exterior(0, 0, float("nan")), "parameter Z0"),
    (lambda: GeneralHousing((Plane.from_coefficients(0, 0, 1),), (1.0,)), "parameter indices"),
])
def test_invalid_housing_parameters_are_named(build, parameter):
    with pytest.raises(InvalidParameterError, match=parameter):
        build()


def test_non_finite_pixels_and_points_are_refused():
    camera = make_camera(HOUSINGS["flat-port"])
    with pytest.raises(InvalidParameterError, match="pixels"):
        camera.rays(np.array([[1.0, np.nan]]))
    with pytest.raises(InvalidParameterError, match="points"):
        camera.project(np.array([[1.0, 2.0, np.inf]]))


@pytest.mark.parametrize("name", sorted(HOUSINGS))
def test_ray_derivatives_match_finite_differences(name):
    camera = make_camera(HOUSINGS[name])
    pixels = frame_grid(160)
    bundle, d_origins, d_directions = camera.rays_with_derivatives(pixels)
    np.testing.assert_allclose(bundle.directions, camera.rays(pixels).directions, atol=1e-15)
    h = 1e-3
    for column in range(2):
        step = np.zeros(2)
        step[column] = h
        ahead, behind = camera.rays(pixels + step), camera.rays(pixels - step)
        numeric_o = (ahead.origins - behind.origins) / (2 * h)
        numeric_d = (ahead.directions - behind.directions) / (2 * h)
        scale_o = np.abs(numeric_o).max()
        np.testing.assert_allclose(d_origins[:, :, column], numeric_o, atol=1e-6 * max(scale_o, 1e-9))
        np.testing.assert_allclose(d_directions[:, :, column], numeric_d, atol=1e-6 * np.abs(numeric_d).max())


def test_single_point_projection_raises_with_the_reason():
    from usvips.core.errors import DegenerateGeometryError

    camera = make_camera(HOUSINGS["flat-port"], exterior=Exterior(0, 0, 0))
    assert camera.project_point([0.05, 0.02, -2.0]).shape == (2,)
    with pytest.raises(DegenerateGeometryError, match="not in front of the camera"):
        camera.project_point([0.0, 0.0, 2.0])
    with pytest.raises(DegenerateGeometryError, match="point 0: .*not in front"):
        camera.project(np.array([[0.0, 0.0, 2.0]])).require_ok()
    with pytest.raises(InvalidParameterError, match="parameter point"):
        camera.project_point([0.0, np.nan, 2.0])


def test_planar_stacks_of_any_depth_and_order_of_indices_round_trip():
    # three parallel planes (a laminated port), and a camera in water looking out into air
    normal = np.array([0.02, -0.03, 1.0])
    laminated = GeneralHousing((Plane(normal, 0.05), Plane(normal, 0.06), Plane(normal, 0.075)),
                               (1.0, 1.5, 1.7, 1.33))
    inverted = GeneralHousing((Plane(normal, 0.05), Plane(normal, 0.06)), (1.33, 1.5, 1.0))
    for housing in (laminated, inverted):
        assert housing.is_planar_stack
        camera = make_camera(housing)
        bundle = camera.rays(frame_grid(80))
        pixels = frame_grid(80)[bundle.ok]
        assert len(pixels) > 100
        points = bundle.origins[bundle.ok] + 1.7 * bundle.directions[bundle.ok]
        projection = camera.project(points)
        assert projection.ok.all()
        assert np.max(np.abs(projection.pixels - pixels)) < 1e-6


def _random_axial_housing(kind: str, rng: np.random.Generator):
    """An axial housing of ``kind`` with a random decentring: a dome port's perspective centre anywhere
    within 4 mm of its dome centre (often mostly across the axis, so the symmetry axis looks sideways), a
    dome cover's sphere centre on the optical axis, a flat port tilted at random."""
    if kind == "dome-port":
        direction = rng.standard_normal(3)
        if rng.random() < 0.5:
            direction[2] *= 0.05  # mostly across the optical axis: dz ≈ 0
        offset = direction / np.linalg.norm(direction) * rng.uniform(0.0005, 0.004)
        return DomePortHousing(*offset, rng.uniform(0.04, 0.08), rng.uniform(0.004, 0.012),
                               rng.uniform(1.46, 1.52), rng.uniform(1.33, 1.35))
    if kind == "dome-cover":
        return DomeCoverHousing(0.0, 0.0, rng.uniform(-0.03, 0.03), 0.09, 0.0, 0.0, rng.uniform(0.13, 0.16),
                                rng.uniform(1.5, 1.6), 1.34)
    return FlatPortHousing(rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(0.02, 0.08),
                           rng.uniform(0.005, 0.02), rng.uniform(1.45, 1.7), 1.34)


@pytest.mark.parametrize("kind", ["dome-port", "dome-cover", "flat-port"])
def test_axial_housings_round_trip_over_random_decentrings(kind):
    """project ∘ rays returns to the pixel to 1e-6 px over the whole frame for random decentrings (also a
    dome port decentred across its axis, whose far side lies more than 90° from the axis); points anywhere
    around the camera get an honest status: OK or OUTSIDE_FRAME only where the solved pixel's ray really
    passes through the point, BEHIND_CAMERA for every point behind the camera."""
    rng = np.random.default_rng(20261126)
    interior = Interior(f=700.0, xp=640.0, yp=480.0, sy=1.0, k1=-0.05)
    far_side = 0
    for _ in range(25):
        housing = _random_axial_housing(kind, rng)
        assert housing.axis is not None
        camera = Camera(interior, Exterior(0, 0, 0), housing, 1280, 960)
        pixels = np.column_stack([rng.uniform(-0.4, 1279.4, 300), rng.uniform(-0.4, 959.4, 300)])
        rays = camera.rays(pixels)
        assert np.all(rays.ok)
        points = rays.origins + rng.uniform(0.3, 8.0, 300)[:, None] * rays.directions
        projection = camera.project(points)
        assert np.all(projection.status == RayStatus.OK)
        np.testing.assert_allclose(projection.pixels, pixels, atol=1e-6)
        far_side += int(np.sum(np.degrees(np.arccos(np.clip(points @ housing.axis / np.linalg.norm(points, axis=1),
                                                                 -1, 1))) > 90.0))
        # anywhere around the camera (a lens without distortion, which cannot fold far outside the frame,
        # and no frame): every status is honest
        camera = Camera(interior.with_values(k1=0.0), Exterior(0, 0, 0), housing)
        anywhere = rng.standard_normal((300, 3)) * rng.uniform(0.3, 8.0, (300, 1))
        projection = camera.project(anywhere)
        behind = anywhere[:, 2] >= 0.0
        assert np.all(projection.status[behind] == RayStatus.BEHIND_CAMERA)
        assert not np.any(projection.status == RayStatus.NOT_CONVERGED)
        seen = projection.status == RayStatus.OK
        # a dome port's glass surrounds the camera: it reaches every point in front
        assert seen[~behind].mean() > (0.95 if kind == "dome-port" else 0.5)
        back = camera.rays(projection.pixels[seen])
        w = anywhere[seen] - back.origins
        along = np.einsum("ij,ij->i", w, back.directions)
        miss = np.linalg.norm(w - along[:, None] * back.directions, axis=1)
        assert np.all(back.ok) and np.all(along > 0)
        assert np.max(miss) < 1e-7
        # a point no ray reaches is named so: the rays of a fine fan in its plane of refraction all pass it
        # on one side (a change of side between two rays would put a ray through it)
        # (or lies in the housing, or needs a ray out of the camera's back: not in front of the housing)
        unreached = ~behind & ~seen
        assert np.all(np.isin(projection.status[unreached], (RayStatus.MISSED_SURFACE, RayStatus.BEHIND_CAMERA,
                                                             RayStatus.TOTAL_INTERNAL_REFLECTION)))
        _assert_no_ray_reaches(housing, anywhere[np.flatnonzero(unreached)[:10]])
    if kind == "dome-port":
        assert far_side > 100  # the sideways-decentred domes really put points beyond 90° from the axis


def _assert_no_ray_reaches(housing, points: np.ndarray) -> None:
    """Trace a fan of 2001 rays from 0 to π about the axis in each point's plane of refraction: no two
    neighbouring rays that get through, leave the camera forwards and run towards the point pass it on
    opposite sides (else a ray between them would reach it)."""
    axis = housing.axis
    theta = np.linspace(0.0, np.pi, 2001)
    for point in points:
        radial = point - (point @ axis) * axis
        e_r = radial / np.linalg.norm(radial)
        directions = np.cos(theta)[:, None] * axis + np.sin(theta)[:, None] * e_r
        bundle = housing.trace(np.zeros_like(directions), directions)
        w = point - bundle.origins
        side = np.sign((w @ axis) * (bundle.directions @ e_r) - (w @ e_r) * (bundle.directions @ axis))
        usable = (bundle.status == RayStatus.OK) & (directions[:, 2] < 0) & \
            (np.einsum("ij,ij->i", w, bundle.directions) > 0)
        crossing = usable[:-1] & usable[1:] & (side[:-1] != side[1:])
        assert not np.any(crossing), point


@pytest.mark.parametrize("name", ["air", "flat-port", "dome-port"])  # (a dome cover sees less than 69°)
def test_a_point_beyond_the_lens_fold_is_outside_the_frame_not_a_folded_pixel(name):
    """k1 < 0 folds the distortion polynomial far outside the frame, mapping wide directions back into
    it: over random points all round a framed camera, every point given a pixel (status OK) lies on that
    pixel's ray, and those beyond the fold are OUTSIDE_FRAME."""
    rng = np.random.default_rng(7)
    interior = Interior(f=700.0, xp=640.0, yp=480.0, sy=1.0, k1=-0.05)  # folds at 69° off the axis
    camera = Camera(interior, Exterior(0, 0, 0), HOUSINGS[name], 1280, 960)
    beyond = 0
    for _ in range(10):
        points = rng.standard_normal((1000, 3)) * rng.uniform(0.5, 8.0, (1000, 1))
        projection = camera.project(points)
        seen = projection.status == RayStatus.OK
        assert seen.sum() > 20
        back = camera.rays(projection.pixels[seen])
        w = points[seen] - back.origins
        along = np.einsum("ij,ij->i", w, back.directions)
        assert np.all(along > 0)
        assert np.max(np.linalg.norm(w - along[:, None] * back.directions, axis=1)) < 1e-7
        unbounded = Camera(interior, Exterior(0, 0, 0), HOUSINGS[name]).project(points)
        in_frame = np.all((unbounded.pixels > -0.5) & (unbounded.pixels < [1279.5, 959.5]), axis=1)
        folded = (unbounded.status == RayStatus.OK) & in_frame & ~seen
        assert np.all(projection.status[folded] == RayStatus.OUTSIDE_FRAME)
        beyond += int(folded.sum())
    assert beyond > 10  # the case arose: wide directions folded back into the frame
