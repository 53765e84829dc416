"""Rotation matrices and the rpy convention of the file formats.

rpy = [rx, ry, rz] means R = Rz(rz) @ Ry(ry) @ Rx(rx): fixed axes X, then Y, then Z, as in
URDF and equal to KUKA's (A, B, C) = (rz, ry, rx).
"""
import numpy as np


def rot_x(angle):
    """Rotation about x by ``angle`` (rad); batched over the shape of ``angle``."""
    c, s = np.cos(angle), np.sin(angle)
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack([o, z, z, z, c, -s, z, s, c], axis=-1).reshape(np.shape(c) + (3, 3))


def rot_y(angle):
    """Rotation about y by ``angle`` (rad)."""
    c, s = np.cos(angle), np.sin(angle)
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack([c, z, s, z, o, z, -s, z, c], axis=-1).reshape(np.shape(c) + (3, 3))


def rot_z(angle):
    """Rotation about z by ``angle`` (rad)."""
    c, s = np.cos(angle), np.sin(angle)
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack([c, -s, z, s, c, z, z, z, o], axis=-1).reshape(np.shape(c) + (3, 3))


def rpy_to_matrix(rpy):
    """(..., 3) roll, pitch, yaw (rad) -> (..., 3, 3) rotation matrices."""
    from scipy.spatial.transform import Rotation  # loaded when used: the command line starts faster
    rpy = np.asarray(rpy, dtype=float)
    flat = rpy.reshape(-1, 3)
    # Extrinsic 'xyz' in SciPy is exactly Rz @ Ry @ Rx.
    mats = Rotation.from_euler("xyz", flat).as_matrix()
    return mats.reshape(rpy.shape[:-1] + (3, 3))


def matrix_to_rpy(matrix):
    """(..., 3, 3) rotation matrices -> (..., 3) roll, pitch, yaw (rad).

    Exact to rounding everywhere, including near pitch = ±90 deg where roll and yaw are
    nearly dependent: pitch comes from a well-conditioned atan2, roll from the last row, and
    yaw from what is left, Rz(yaw) = R Rx(roll)^T Ry(pitch)^T, so the triple rebuilds R even
    where roll itself is ill-determined.
    """
    m = np.asarray(matrix, dtype=float)
    pitch = np.arctan2(-m[..., 2, 0], np.hypot(m[..., 0, 0], m[..., 1, 0]))
    roll = np.arctan2(m[..., 2, 1], m[..., 2, 2])
    rest = m @ np.swapaxes(rot_x(roll), -1, -2) @ np.swapaxes(rot_y(pitch), -1, -2)
    yaw = np.arctan2(rest[..., 1, 0], rest[..., 0, 0])
    return np.stack([roll, pitch, yaw], axis=-1)
