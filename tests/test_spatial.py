import numpy as np
import pytest

from robocal import spatial as sp


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def test_rpy_matches_fixed_xyz_convention(rng):
    rpy = rng.uniform(-3, 3, (50, 3))
    expected = sp.rot_z(rpy[:, 2]) @ sp.rot_y(rpy[:, 1]) @ sp.rot_x(rpy[:, 0])
    np.testing.assert_allclose(sp.rpy_to_matrix(rpy), expected, atol=1e-15)
    np.testing.assert_allclose(sp.rpy_to_matrix(sp.matrix_to_rpy(expected)), expected, atol=1e-14)


def test_kuka_abc_example():
    # KUKA A, B, C = rz, ry, rx: A = 90 turns x onto y.
    R = sp.rpy_to_matrix(np.radians([0.0, 0.0, 90.0]))
    np.testing.assert_allclose(R @ [1, 0, 0], [0, 1, 0], atol=1e-15)


def test_so3_and_se3_round_trips_including_small_and_near_pi_angles(rng):
    w = np.vstack([rng.normal(size=(20, 3)), [[1e-12, 0, 0], [0, 0, np.pi - 1e-3], [0, 2.5, 0]]])
    np.testing.assert_allclose(sp.so3_log(sp.so3_exp(w)), w, atol=1e-9)
    xi = np.hstack([rng.normal(size=(20, 3)) * 100, rng.normal(size=(20, 3))])
    np.testing.assert_allclose(sp.se3_log(sp.se3_exp(xi)), xi, atol=1e-9)


def test_so3_exp_is_a_rotation(rng):
    R = sp.so3_exp(rng.normal(size=(10, 3)) * 2)
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-14)


def test_adjoint_maps_twists_consistently(rng):
    # exp(Ad_T xi) = T exp(xi) T^-1
    T = sp.se3_exp(rng.normal(size=6))
    xi = rng.normal(size=6) * 0.3
    lhs = sp.se3_exp(sp.adjoint(T) @ xi)
    rhs = T @ sp.se3_exp(xi) @ sp.invert(T)
    np.testing.assert_allclose(lhs, rhs, atol=1e-12)


def test_invert_and_transform_points(rng):
    T = sp.se3_exp(rng.normal(size=(5, 6)))
    np.testing.assert_allclose(T @ sp.invert(T), np.broadcast_to(np.eye(4), T.shape), atol=1e-13)
    p = rng.normal(size=(5, 3))
    np.testing.assert_allclose(sp.transform_points(sp.invert(T), sp.transform_points(T, p)), p, atol=1e-13)


def test_rpy_round_trip_is_exact_near_gimbal_lock(rng):
    pitch = np.pi / 2 - 10 ** rng.uniform(-12, -1, 400) * rng.choice([-1, 1], 400)
    pitch[:200] *= -1
    rpy = np.column_stack([rng.uniform(-3, 3, 400), pitch, rng.uniform(-3, 3, 400)])
    R = sp.rpy_to_matrix(rpy)
    np.testing.assert_allclose(sp.rpy_to_matrix(sp.matrix_to_rpy(R)), R, atol=2e-15)
