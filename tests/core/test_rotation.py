import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from usvips.core.rotation import angles_from_matrix, image_to_object, object_to_image, rotation_matrix

angle = st.floats(-3.1, 3.1)
small_phi = st.floats(-1.5, 1.5)


@given(angle, small_phi, angle)
def test_rotation_is_orthonormal_and_round_trips(omega, phi, kappa):
    m = rotation_matrix(omega, phi, kappa)
    np.testing.assert_allclose(m @ m.T, np.eye(3), atol=1e-14)
    assert np.linalg.det(m) > 0
    np.testing.assert_allclose(angles_from_matrix(m), (omega, phi, kappa), atol=1e-9)


def test_matrix_matches_thesis_b1_elements():
    omega, phi, kappa = 0.3, -0.2, 0.7
    m = rotation_matrix(omega, phi, kappa)
    so, co, sp, cp, sk, ck = np.sin(omega), np.cos(omega), np.sin(phi), np.cos(phi), np.sin(kappa), np.cos(kappa)
    expected = [[cp * ck, co * sk + so * sp * ck, so * sk - co * sp * ck],
                [-cp * sk, co * ck - so * sp * sk, so * ck + co * sp * sk],
                [sp, -so * cp, co * cp]]
    np.testing.assert_allclose(m, expected, atol=1e-15)


def test_sequence_is_omega_then_phi_then_kappa():
    def r_omega(a):
        return np.array([[1, 0, 0], [0, np.cos(a), np.sin(a)], [0, -np.sin(a), np.cos(a)]])

    def r_phi(a):
        return np.array([[np.cos(a), 0, -np.sin(a)], [0, 1, 0], [np.sin(a), 0, np.cos(a)]])

    def r_kappa(a):
        return np.array([[np.cos(a), np.sin(a), 0], [-np.sin(a), np.cos(a), 0], [0, 0, 1]])

    m = rotation_matrix(0.4, 0.5, -0.6)
    np.testing.assert_allclose(m, r_kappa(-0.6) @ r_phi(0.5) @ r_omega(0.4), atol=1e-15)


def test_directions_of_rotation():
    m = rotation_matrix(0.1, 0.2, 0.3)
    v = np.array([[1.0, 2.0, 3.0]])
    np.testing.assert_allclose(image_to_object(m, object_to_image(m, v)), v, atol=1e-14)
    np.testing.assert_allclose(object_to_image(m, v)[0], m @ v[0])


def test_vectorised_over_angles():
    omegas = np.linspace(-1, 1, 5)
    ms = rotation_matrix(omegas, 0.1, 0.2)
    assert ms.shape == (5, 3, 3)
    np.testing.assert_allclose(ms[3], rotation_matrix(omegas[3], 0.1, 0.2))
