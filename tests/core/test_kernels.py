"""The compiled kernels give the numpy reference path's numbers (1e-9 m, 1e-6 px) over random cameras,
housings and pixels, failures included."""

import numpy as np
import pytest

from tests.core.scenes import HOUSINGS
from usvips.core import kernels
from usvips.core.calibration.point_derivatives import ideal_rays
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import ConvergenceError
from usvips.core.housing import AirHousing, DomeCoverHousing, FlatPortHousing, GeneralHousing
from usvips.core.interior import Interior
from usvips.core.intersection import intersect, intersect_traced, trace
from usvips.core.rays import RayStatus
from usvips.core.surfaces import Plane, Sphere

pytestmark = pytest.mark.skipif(not kernels.available(), reason="numba is not installed")

WIDTH, HEIGHT = 1280, 960
SEEDS = range(10)


def random_interior(rng: np.random.Generator) -> Interior:
    return Interior(f=rng.uniform(1000, 1600), xp=rng.uniform(600, 680), yp=rng.uniform(440, 520),
                    sy=rng.uniform(0.97, 1.03), k1=rng.uniform(-0.12, 0.1), k2=rng.uniform(0.0, 0.05),
                    p1=rng.uniform(-1e-3, 1e-3), p2=rng.uniform(-1e-3, 1e-3))


def random_housing(rng: np.random.Generator, kind: str):
    """A random housing of one kind: flat port, dome cover (off-axis sphere), a glass wedge (two planes
    that are not parallel) or two spheres and a plane."""
    if kind == "flat-port":
        return FlatPortHousing(rng.uniform(-0.05, 0.05), rng.uniform(-0.05, 0.05), rng.uniform(0.02, 0.1),
                               rng.uniform(0.004, 0.03), rng.uniform(1.45, 1.75), rng.uniform(1.33, 1.35))
    if kind == "dome-cover":
        a, b, c = rng.uniform(-0.006, 0.006), rng.uniform(-0.006, 0.006), rng.uniform(-0.01, 0.04)
        r = rng.uniform(0.07, 0.12)
        d, e = rng.uniform(-0.03, 0.03), rng.uniform(-0.03, 0.03)
        g = r * np.sqrt(d * d + e * e + 1) - (d * a + e * b + c) + rng.uniform(0.003, 0.03)
        return DomeCoverHousing(a, b, c, r, d, e, g, rng.uniform(1.45, 1.75), rng.uniform(1.33, 1.35))
    if kind == "wedge":
        inner = Plane.from_coefficients(rng.uniform(-0.05, 0.05), rng.uniform(-0.05, 0.05), rng.uniform(0.04, 0.08))
        outer = Plane.from_coefficients(rng.uniform(-0.08, 0.08), rng.uniform(-0.08, 0.08), rng.uniform(0.1, 0.13))
        return GeneralHousing((inner, outer), (1.0, rng.uniform(1.45, 1.75), 1.34))
    center = rng.uniform(-0.004, 0.004, 3)
    r = rng.uniform(0.08, 0.1)
    return GeneralHousing((Sphere(center, r), Sphere(center + rng.uniform(-0.002, 0.002, 3), r + 0.008),
                           Plane.from_coefficients(rng.uniform(-0.03, 0.03), rng.uniform(-0.03, 0.03), 0.2)),
                          (1.0, 1.5, 1.6, 1.34))


KINDS = ("flat-port", "dome-cover", "wedge", "spheres")


def random_camera(rng: np.random.Generator, kind: str, position=(0.0, 0.0, 0.0)) -> Camera:
    exterior = Exterior(*position, rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(-0.3, 0.3))
    return Camera(random_interior(rng), exterior, random_housing(rng, kind), WIDTH, HEIGHT)


def frame_pixels(rng: np.random.Generator, n: int) -> np.ndarray:
    """Pixels over the frame and a band beyond it (where rays may miss or reflect), corners included."""
    pixels = np.column_stack([rng.uniform(-60, WIDTH + 60, n), rng.uniform(-60, HEIGHT + 60, n)])
    pixels[:4] = [[0, 0], [WIDTH - 1, 0], [0, HEIGHT - 1], [WIDTH - 1, HEIGHT - 1]]
    return pixels


def both(function):
    with kernels.mode("never"):
        reference = function()
    with kernels.mode("always"):
        compiled = function()
    return reference, compiled


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("seed", SEEDS[:5])
def test_compiled_rays_of_ideal_coordinates_match_the_reference(kind, seed):
    """The rays the calibration's housing derivatives trace (ideal coordinates, no derivatives) are the
    camera's rays of the pixels the lens maps there."""
    rng = np.random.default_rng(seed)
    camera = random_camera(rng, kind)
    pixels = frame_pixels(rng, 800)
    ideal = camera.interior.pixels_to_normalised(pixels)
    steep = rng.uniform(-6, 6, (200, 2))  # far beyond any lens: rays that graze the surfaces
    ref, fast = both(lambda: ideal_rays(camera, np.vstack([ideal, steep])))
    np.testing.assert_array_equal(fast.status, ref.status)
    np.testing.assert_array_equal(fast.failed_surface, ref.failed_surface)
    ok = ref.ok
    np.testing.assert_allclose(fast.origins[ok], ref.origins[ok], rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.directions[ok], ref.directions[ok], rtol=0, atol=1e-12)
    ok = ref.ok[:len(pixels)]
    assert ok.sum() > 500
    with kernels.mode("never"):
        through_lens = camera.rays(pixels)
    np.testing.assert_array_equal(ref.status[:len(pixels)], through_lens.status)
    np.testing.assert_allclose(ref.origins[:len(pixels)][ok], through_lens.origins[ok], rtol=0, atol=1e-12)
    np.testing.assert_allclose(ref.directions[:len(pixels)][ok], through_lens.directions[ok], rtol=0, atol=1e-12)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("seed", SEEDS)
def test_compiled_trace_with_derivatives_matches_the_reference(kind, seed):
    rng = np.random.default_rng(seed)
    camera = random_camera(rng, kind)
    pixels = frame_pixels(rng, 800)
    (ref, ref_do, ref_dd), (fast, fast_do, fast_dd) = both(lambda: camera.rays_with_derivatives(pixels))
    np.testing.assert_array_equal(fast.status, ref.status)
    np.testing.assert_array_equal(fast.failed_surface, ref.failed_surface)
    ok = ref.ok
    assert ok.sum() > 500
    np.testing.assert_allclose(fast.origins[ok], ref.origins[ok], rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.directions[ok], ref.directions[ok], rtol=0, atol=1e-12)
    # per pixel: metres (origins) and radians (directions); both about 1e-3 per pixel
    np.testing.assert_allclose(fast_do[ok], ref_do[ok], rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast_dd[ok], ref_dd[ok], rtol=0, atol=1e-12)


def _pair_scene(rng, kind, n):
    left = random_camera(rng, kind)
    right = random_camera(rng, kind, position=(rng.uniform(0.2, 0.5), rng.uniform(-0.05, 0.05), 0.0))
    pixels = np.column_stack([rng.uniform(0, WIDTH - 1, 2 * n), rng.uniform(0, HEIGHT - 1, 2 * n)])
    with kernels.mode("never"):
        rays = left.rays(pixels)
        points = rays.origins + rng.uniform(1.0, 5.0, 2 * n)[:, None] * rays.directions
        pl, pr = left.project(points), right.project(points)
    keep = np.flatnonzero(rays.ok & pl.ok & pr.ok)[:n]
    return left, right, points[keep], pl.pixels[keep], pr.pixels[keep]


def assert_same_intersection(fast, ref):
    """The same statuses, points to 1e-9 m, covariances to 1e-9 of their largest entry, residuals to
    1e-9 m and 1e-6 px."""
    np.testing.assert_array_equal(fast.status, ref.status)
    np.testing.assert_allclose(fast.points, ref.points, rtol=0, atol=1e-9)
    scale = np.abs(ref.covariance).max(axis=(1, 2), keepdims=True) + 1e-300
    np.testing.assert_allclose(fast.covariance / scale, ref.covariance / scale, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast.residuals_m, ref.residuals_m, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast.residuals_px, ref.residuals_px, rtol=0, atol=1e-6)


def traced_then_intersected(cameras, pixels, sigma):
    """:func:`intersect` by its two public steps (trace each camera, then intersect the traced rays)."""
    return intersect_traced([trace(camera, p) for camera, p in zip(cameras, pixels, strict=True)], sigma)


@pytest.mark.parametrize("route", [intersect, traced_then_intersected])
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("seed", SEEDS)
def test_compiled_intersection_matches_the_reference(kind, seed, route):
    rng = np.random.default_rng(100 + seed)
    left, right, points, pix_left, pix_right = _pair_scene(rng, kind, 700)
    sigma = rng.uniform(0.2, 1.0, (len(points) + 2, 2))  # pixels, per observation
    pix_left = pix_left + sigma[:-2, :1] * rng.normal(0, 1, pix_left.shape)
    pix_right = pix_right + sigma[:-2, 1:] * rng.normal(0, 1, pix_right.shape)
    # a row far outside the frame (its ray fails or points away), and one that pairs unrelated pixels
    pix_left = np.vstack([pix_left, [[-5000.0, -5000.0]], pix_left[:1]])
    pix_right = np.vstack([pix_right, pix_right[:1], pix_left[:1]])
    ref, fast = both(lambda: route([left, right], [pix_left, pix_right], sigma))
    np.testing.assert_array_equal(fast.status, ref.status)
    ok = ref.ok
    assert ok.sum() >= 400 and not ok[-2]
    assert_same_intersection(fast, ref)
    # and both are the truth to within the noise: mean squared normalised error near 1 over the points
    m = len(points)
    error = fast.points[:m][ok[:m]] - points[ok[:m]]
    inverse = np.linalg.inv(fast.covariance[:m][ok[:m]])
    msne = float(np.mean(np.einsum("ni,nij,nj->n", error, inverse, error)) / 3)
    assert 0.7 < msne < 1.4


@pytest.mark.parametrize("seed", SEEDS)
def test_fused_intersection_of_three_cameras_in_different_housings_matches_the_reference(seed):
    """k = 3 cameras, each in a housing of its own kind (or in air), a sigma per camera, a row count that
    is no multiple of the compiled block; the points match the truth to within the noise."""
    rng = np.random.default_rng(600 + seed)
    kinds = rng.choice(KINDS + ("air",), 3)
    cameras = []
    for j, kind in enumerate(kinds):
        camera = random_camera(rng, "flat-port" if kind == "air" else kind,
                               position=(0.3 * j, rng.uniform(-0.05, 0.05), rng.uniform(-0.05, 0.05)))
        cameras.append(Camera(camera.interior, camera.exterior, AirHousing(), WIDTH, HEIGHT) if kind == "air"
                       else camera)
    n = 5 * 701
    with kernels.mode("never"):
        rays = cameras[0].rays(np.column_stack([rng.uniform(0, WIDTH - 1, n), rng.uniform(0, HEIGHT - 1, n)]))
        points = rays.origins + rng.uniform(1.5, 5.0, n)[:, None] * rays.directions
        projections = [camera.project(points) for camera in cameras]
    keep = np.flatnonzero(rays.ok & np.all([p.ok for p in projections], axis=0))[:701]
    assert len(keep) == 701
    sigma = rng.uniform(0.2, 1.0, 3)
    pixels = [p.pixels[keep] + s * rng.normal(0, 1, (len(keep), 2)) for p, s in zip(projections, sigma, strict=True)]
    ref, fast = both(lambda: intersect(cameras, pixels, sigma))
    assert ref.ok.all()
    assert_same_intersection(fast, ref)
    error = fast.points - points[keep]
    msne = float(np.mean(np.einsum("ni,nij,nj->n", error, np.linalg.inv(fast.covariance), error)) / 3)
    assert 0.7 < msne < 1.4


def test_fused_intersection_names_parallel_rays_points_behind_and_rays_that_miss():
    """Statuses of the compiled fused path are the reference's: two cameras side by side with the same
    lens and a cover plane tilted so steeply that rays beyond x̄ = f miss it."""
    rng = np.random.default_rng(700)
    housing = GeneralHousing((Plane.from_coefficients(1.0, 0.0, 0.1),), (1.0, 1.34))
    left = Camera(random_interior(rng), Exterior(0.0, 0.0, 0.0, 0.01, -0.02, 0.005), housing, WIDTH, HEIGHT)
    right = Camera(left.interior, Exterior(0.3, 0.0, 0.0, 0.01, -0.02, 0.005), housing, WIDTH, HEIGHT)
    n = 600
    pix_left = frame_pixels(rng, n)
    pix_right = pix_left + [-120.0, 3.0] + rng.normal(0, 2.0, (n, 2))
    pix_right[:100] = pix_left[:100]  # the same pixel in both: parallel rays
    pix_left[100:200, 0], pix_right[100:200, 0] = rng.uniform(0, 50, 100), rng.uniform(1230, 1279, 100)  # diverging
    pix_left[200:260, 0] = rng.uniform(3000, 4000, 60)  # beyond the tilted plane's reach
    ref, fast = both(lambda: intersect([left, right], [pix_left, pix_right], 0.5))
    assert {RayStatus.PARALLEL_RAYS, RayStatus.DIVERGING_RAYS, RayStatus.FAILED_RAY, RayStatus.OK} <= set(ref.status)
    assert np.all(ref.status[:100] == RayStatus.PARALLEL_RAYS) and np.all(ref.status[200:260] == RayStatus.FAILED_RAY)
    assert_same_intersection(fast, ref)


@pytest.mark.parametrize("rows", [1, 255, 256, 257, 513])
def test_fused_intersection_at_block_edges(rows):
    rng = np.random.default_rng(rows)
    left, right, points, pix_left, pix_right = _pair_scene(rng, "dome-cover", rows)
    ref, fast = both(lambda: intersect([left, right], [pix_left, pix_right], 0.7))
    assert len(fast.status) == rows
    assert_same_intersection(fast, ref)


def test_fused_intersection_through_a_strongly_distorting_lens():
    """Pixels whose undistortion needs more than the first pass's Newton steps give the reference's points."""
    rng = np.random.default_rng(800)
    left, right, points, pix_left, pix_right = _pair_scene(rng, "flat-port", 900)
    strong = left.interior.with_values(k1=-0.3, k2=0.08, k3=-0.01, p1=2e-3, p2=-1.5e-3)
    left, right = Camera(strong, left.exterior, left.housing), Camera(strong, right.exterior, right.housing)
    ref, fast = both(lambda: intersect([left, right], [pix_left, pix_right], 0.5))
    assert ref.ok.sum() > 800
    assert_same_intersection(fast, ref)


def test_a_distortion_that_folds_is_named_when_intersecting():
    interior = Interior(f=1000.0, xp=640.0, yp=480.0, k1=-0.6)
    left = Camera(interior, Exterior(0, 0, 0), HOUSINGS["flat-port"], WIDTH, HEIGHT)
    right = Camera(interior, Exterior(0.3, 0, 0), HOUSINGS["flat-port"], WIDTH, HEIGHT)
    pixels = np.vstack([np.full((600, 2), 640.0), [[1279.0, 959.0]]])
    with kernels.mode("always"), pytest.raises(ConvergenceError, match="row 600"):
        intersect([left, right], [pixels, pixels - [50.0, 0.0]], 0.5)


@pytest.mark.parametrize("kind", ("dome-cover", "wedge", "spheres"))
@pytest.mark.parametrize("seed", SEEDS)
def test_compiled_back_projection_matches_the_reference(kind, seed):
    rng = np.random.default_rng(200 + seed)
    camera = random_camera(rng, kind)
    with kernels.mode("never"):
        rays = camera.rays(frame_pixels(rng, 900))
    points = rays.origins + rng.uniform(0.5, 6.0, len(rays))[:, None] * rays.directions
    points[-10:] = camera.exterior.to_object(rng.uniform(-1, 1, (10, 3)) * [1, 1, 0] + [0, 0, 1.0])  # behind
    ref, fast = both(lambda: camera.project(points))
    np.testing.assert_array_equal(fast.status, ref.status)
    assert ref.ok.sum() > 300
    np.testing.assert_allclose(fast.pixels[ref.ok], ref.pixels[ref.ok], rtol=0, atol=1e-6)
    # a warm start (slightly different answers) reaches the same pixels
    warm = ref.pixels + rng.normal(0, 2.0, ref.pixels.shape)
    warm_ref, warm_fast = both(lambda: camera.project(points, start_pixels=warm))
    np.testing.assert_array_equal(warm_fast.status[ref.ok], warm_ref.status[ref.ok])
    good = warm_ref.ok & ref.ok
    np.testing.assert_allclose(warm_fast.pixels[good], ref.pixels[good], rtol=0, atol=1e-6)


def test_a_distortion_that_folds_is_named_by_the_reference_path():
    interior = Interior(f=1000.0, xp=640.0, yp=480.0, k1=-0.6)
    camera = Camera(interior, Exterior(0, 0, 0), HOUSINGS["flat-port"], WIDTH, HEIGHT)
    pixels = np.vstack([np.full((600, 2), 640.0), [[1279.0, 959.0]]])
    with kernels.mode("always"), pytest.raises(ConvergenceError, match="row 600"):
        camera.rays_with_derivatives(pixels)


def test_the_modes_choose_the_path():
    implicit = HOUSINGS["implicit"].surfaces
    flat = HOUSINGS["flat-port"].surfaces
    with kernels.mode("auto"):
        assert not kernels.wanted(kernels.MIN_ROWS - 1, flat)
        assert kernels.wanted(kernels.MIN_ROWS, flat)
        assert not kernels.wanted(10**6, implicit)  # only planes and spheres compile
    with kernels.mode("never"):
        assert not kernels.wanted(10**6, flat)
    with kernels.mode("always"):
        assert kernels.wanted(1, flat)
    with pytest.raises(ValueError, match="kernel mode"), kernels.mode("fast"):
        pass
    assert RayStatus.OK == 0


@pytest.mark.parametrize("seed", SEEDS)
def test_compiled_flat_port_back_projection_matches_the_reference(seed):
    rng = np.random.default_rng(300 + seed)
    camera = random_camera(rng, "flat-port")
    assert camera.housing.is_planar_stack
    with kernels.mode("never"):
        rays = camera.rays(frame_pixels(rng, 900))
    points = rays.origins + rng.uniform(0.05, 6.0, len(rays))[:, None] * rays.directions
    points[-10:] = camera.exterior.to_object(rng.uniform(-1, 1, (10, 3)) * [1, 1, 0] + [0, 0, 1.0])  # behind
    points[-20:-10] = camera.exterior.to_object(rng.uniform(-0.01, 0.01, (10, 3)) - [0, 0, 0.03])  # in the port
    ref, fast = both(lambda: camera.project(points))
    np.testing.assert_array_equal(fast.status, ref.status)
    assert ref.ok.sum() > 600 and (~ref.ok).sum() >= 20
    np.testing.assert_allclose(fast.pixels[ref.ok], ref.pixels[ref.ok], rtol=0, atol=1e-6)


@pytest.mark.parametrize("seed", SEEDS)
def test_compiled_undistortion_matches_the_reference_with_every_term(seed):
    rng = np.random.default_rng(400 + seed)
    interior = random_interior(rng).with_values(k3=rng.uniform(-0.05, 0.05))
    target = interior.pixels_to_image(frame_pixels(rng, 700)) / interior.f
    ref, fast = both(lambda: interior.undistort(target))
    np.testing.assert_allclose(fast, ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(interior.distort(fast), target, rtol=0, atol=1e-12)


@pytest.mark.parametrize("seed", SEEDS[:4])
def test_compiled_trace_honours_k3(seed):
    rng = np.random.default_rng(500 + seed)
    camera = random_camera(rng, "flat-port")
    camera = Camera(camera.interior.with_values(k3=rng.uniform(-0.05, 0.05)), camera.exterior, camera.housing)
    pixels = frame_pixels(rng, 600)
    (ref, _, _), (fast, _, _) = both(lambda: camera.rays_with_derivatives(pixels))
    np.testing.assert_array_equal(fast.status, ref.status)
    np.testing.assert_allclose(fast.directions[ref.ok], ref.directions[ref.ok], rtol=0, atol=1e-12)


def test_an_undistortion_that_folds_is_named_by_the_reference_path():
    interior = Interior(f=1000.0, xp=640.0, yp=480.0, k1=-0.6)
    target = np.vstack([np.zeros((600, 2)), [[0.64, 0.48]]])
    with kernels.mode("always"), pytest.raises(ConvergenceError, match="row 600"):
        interior.undistort(target)


def test_compiled_rays_of_ideal_coordinates_name_misses_and_total_reflection_as_the_reference():
    tilted = GeneralHousing((Plane.from_coefficients(2.0, 0.0, 0.05), Plane.from_coefficients(2.0, 0.5, 0.06)),
                            (1.0, 1.7, 1.0))
    camera = Camera(Interior(1000, 640, 480), Exterior(0.0, 0.0, 0.0, 0.1, 0.0, 0.0), tilted)
    ideal = np.random.default_rng(1).uniform(-6, 6, (2000, 2))
    ref, fast = both(lambda: ideal_rays(camera, ideal))
    assert {RayStatus.OK, RayStatus.MISSED_SURFACE, RayStatus.TOTAL_INTERNAL_REFLECTION} <= set(ref.status.tolist())
    np.testing.assert_array_equal(fast.status, ref.status)
    np.testing.assert_array_equal(fast.failed_surface, ref.failed_surface)
    np.testing.assert_allclose(fast.origins[ref.ok], ref.origins[ref.ok], rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.directions[ref.ok], ref.directions[ref.ok], rtol=0, atol=1e-12)
