import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from usvips.core.errors import InvalidParameterError
from usvips.core.surfaces import ImplicitSurface, Plane, Sphere, refract

unit_component = st.floats(-1.0, 1.0, allow_nan=False)
vectors = arrays(np.float64, 3, elements=unit_component).filter(lambda v: np.linalg.norm(v) > 0.1)
indices = st.floats(1.0, 2.0)


@settings(max_examples=300, deadline=None)
@given(vectors, vectors, indices, indices)
def test_snell_law_and_coplanarity_hold(direction, normal, n_in, n_out):
    d = direction / np.linalg.norm(direction)
    n = normal / np.linalg.norm(normal)
    refracted, tir = refract(d[None], n[None], n_in, n_out)
    sin_in = np.linalg.norm(np.cross(d, n))
    if abs(n_in * sin_in - n_out) < 1e-9 * n_out:
        return  # grazing the critical angle: either answer is right to rounding
    if n_in * sin_in > n_out:
        assert tir[0]
        return
    assert not tir[0]
    t = refracted[0]
    assert abs(np.linalg.norm(t) - 1) < 1e-12
    sin_out = np.linalg.norm(np.cross(t, n))
    assert abs(n_in * sin_in - n_out * sin_out) < 1e-9                 # Snell (2.8)
    assert abs(np.dot(np.cross(d, n), t)) < 1e-9                      # coplanar with d and n (App. A)
    assert np.sign(t @ n) == np.sign(d @ n) or abs(d @ n) < 1e-12    # transmitted, not reflected


def test_total_internal_reflection_is_flagged():
    d = np.array([[np.sin(1.2), 0.0, -np.cos(1.2)]])
    _, tir = refract(d, np.array([[0.0, 0.0, 1.0]]), 1.5, 1.0)
    assert tir[0]
    _, tir = refract(d, np.array([[0.0, 0.0, 1.0]]), 1.0, 1.5)
    assert not tir[0]


def test_sphere_intersection_takes_the_first_crossing_ahead():
    sphere = Sphere(np.array([0.0, 0.0, -1.0]), 0.5)
    origins = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.0, 0.0]])
    directions = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0]])
    t, hit = sphere.intersect(origins, directions)
    np.testing.assert_allclose(t[:2], [0.5, 0.5])   # from outside: near side; from inside: the exit
    assert hit[:2].all() and not hit[2]              # looking away misses


def test_plane_intersection_sign_fixes_eq_2_22():
    plane = Plane.from_coefficients(0.0, 0.0, 2.0)  # z = -2
    t, hit = plane.intersect(np.zeros((1, 3)), np.array([[0.0, 0.0, -1.0]]))
    assert hit[0] and t[0] == pytest.approx(2.0)
    t, hit = plane.intersect(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))
    assert not hit[0]


def test_implicit_sphere_agrees_with_analytic_sphere():
    center, radius = np.array([0.01, -0.02, -0.3]), 0.2
    implicit = ImplicitSurface(lambda p: np.sum((p - center) ** 2, axis=1) - radius**2,
                               lambda p: 2 * (p - center), reach=1.0, steps=100)
    sphere = Sphere(center, radius)
    rng = np.random.default_rng(3)
    d = np.column_stack([rng.uniform(-0.3, 0.3, 50), rng.uniform(-0.3, 0.3, 50), -np.ones(50)])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.zeros_like(d)
    t1, h1 = implicit.intersect(o, d)
    t2, h2 = sphere.intersect(o, d)
    np.testing.assert_array_equal(h1, h2)
    np.testing.assert_allclose(t1[h1], t2[h2], atol=1e-12)
    p = o[h1] + t1[h1, None] * d[h1]
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", implicit.normals(p), sphere.normals(p))), 1, atol=1e-12)


def test_transformed_surfaces_are_the_same_set():
    rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    shift = np.array([0.1, 0.2, 0.3])
    plane = Plane.from_coefficients(0.1, -0.2, 0.5)
    point_on_plane = np.array([[1.0, 2.0, -0.5 - 0.1 + 0.4]])
    assert abs(plane.evaluate(point_on_plane)[0]) < 1e-12
    moved = point_on_plane @ rotation.T + shift
    assert abs(plane.transformed(rotation, shift).evaluate(moved)[0]) < 1e-12
    sphere = Sphere(np.array([0.0, 0.0, -1.0]), 0.3)
    p = np.array([[0.3, 0.0, -1.0]])
    assert abs(sphere.transformed(rotation, shift).evaluate(p @ rotation.T + shift)[0]) < 1e-12


@pytest.mark.parametrize("build, name", [
    (lambda: Sphere(np.zeros(3), 0.0), "parameter r"),
    (lambda: Sphere(np.zeros(3), -1.0), "parameter r"),
    (lambda: Sphere(np.array([0.0, np.nan, 0.0]), 1.0), "parameter sphere center"),
    (lambda: Plane(np.zeros(3), 1.0), "parameter plane normal"),
    (lambda: Plane.from_coefficients(0.0, 0.0, float("inf")), "parameter g"),
])
def test_invalid_surfaces_name_the_parameter(build, name):
    with pytest.raises(InvalidParameterError, match=name):
        build()
