"""Homogeneous 4x4 transforms, batched over leading axes."""
import numpy as np

from ..errors import InputError

from .rotations import matrix_to_rpy, rpy_to_matrix


def make_transform(rotation=None, position=None):
    """Build (..., 4, 4) transforms from (..., 3, 3) rotations and (..., 3) positions."""
    if rotation is None and position is None:
        return np.eye(4)
    if rotation is None:
        position = np.asarray(position, dtype=float)
        rotation = np.broadcast_to(np.eye(3), position.shape[:-1] + (3, 3))
    rotation = np.asarray(rotation, dtype=float)
    if position is None:
        position = np.zeros(rotation.shape[:-2] + (3,))
    position = np.asarray(position, dtype=float)
    batch = np.broadcast_shapes(rotation.shape[:-2], position.shape[:-1])
    out = np.zeros(batch + (4, 4))
    out[..., :3, :3] = rotation
    out[..., :3, 3] = position
    out[..., 3, 3] = 1.0
    return out


def translation(x=0.0, y=0.0, z=0.0):
    """A pure translation (4, 4)."""
    return make_transform(position=[x, y, z])


def chained(transforms):
    """(n, 4, 4): the running products T1, T1·T2, ..., T1···Tn of consecutive transforms
    ``transforms`` (n, 4, 4), each given in the frame of the one before (a chain's joint
    origins -> its joint frames in the base frame)."""
    out = np.empty((len(transforms), 4, 4))
    current = np.eye(4)
    for k, transform in enumerate(transforms):
        current = current @ transform
        out[k] = current
    return out


def invert(transform):
    """Inverse of rigid transforms (..., 4, 4), using R^T rather than a general inverse."""
    transform = np.asarray(transform, dtype=float)
    rot_t = np.swapaxes(transform[..., :3, :3], -1, -2)
    pos = transform[..., :3, 3]
    return make_transform(rot_t, -np.einsum("...ij,...j->...i", rot_t, pos))


def transform_points(transform, points):
    """Apply (..., 4, 4) transforms to (..., 3) points."""
    transform = np.asarray(transform, dtype=float)
    return np.einsum("...ij,...j->...i", transform[..., :3, :3], points) + transform[..., :3, 3]


def compose_pose(xyz, rpy):
    """(..., 3) position and (..., 3) rpy (rad) -> (..., 4, 4)."""
    return make_transform(rpy_to_matrix(rpy), xyz)


def pose_to_xyz_rpy(transform):
    """(..., 4, 4) -> ((..., 3) position, (..., 3) rpy in rad)."""
    transform = np.asarray(transform, dtype=float)
    return transform[..., :3, 3].copy(), matrix_to_rpy(transform[..., :3, :3])


def kabsch(source, target, weights=None):
    """Rotation R and translation t minimising sum w |R source_i + t - target_i|^2."""
    source = np.asarray(source, dtype=float)
    target = np.asarray(target, dtype=float)
    w = np.ones(len(source)) if weights is None else np.asarray(weights, dtype=float)
    w = w / w.sum()
    mu_s, mu_t = w @ source, w @ target
    cov = (target - mu_t).T @ ((source - mu_s) * w[:, None])
    u, s, vt = np.linalg.svd(cov)
    if s[1] < 1e-9 * max(s[0], 1e-300):
        raise InputError("the measured points are (nearly) collinear: a rigid frame cannot be fitted; "
                         "measure poses spread over the workspace")
    fix = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    rot = u @ fix @ vt
    return rot, mu_t - rot @ mu_s
