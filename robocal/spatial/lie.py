"""Exponential and logarithm maps of SO(3) and SE(3), and the adjoint.

Twists are ordered [v; w] (linear first) to match the [dp; dw] rows of the Jacobians.
The series expansions near zero keep every map accurate to machine precision for tiny
angles, which calibration steps produce all the time.
"""
import numpy as np

from .transforms import make_transform

_SMALL = 1e-6


def hat(w):
    """(..., 3) -> (..., 3, 3) skew-symmetric matrices, hat(w) @ x == cross(w, x)."""
    w = np.asarray(w, dtype=float)
    z = np.zeros(w.shape[:-1])
    x, y, zz = w[..., 0], w[..., 1], w[..., 2]
    return np.stack([z, -zz, y, zz, z, -x, -y, x, z], axis=-1).reshape(w.shape[:-1] + (3, 3))


def vee(m):
    """Inverse of :func:`hat` (takes the skew part of the input)."""
    m = np.asarray(m, dtype=float)
    return 0.5 * np.stack(
        [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]],
        axis=-1,
    )


def _sinc_terms(theta):
    """A = sin t / t, B = (1 - cos t) / t^2, C = (t - sin t) / t^3, Taylor-safe near zero."""
    t2 = theta * theta
    small = theta < _SMALL
    safe = np.where(small, 1.0, theta)
    a = np.where(small, 1.0 - t2 / 6.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 - t2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
    c = np.where(small, 1.0 / 6.0 - t2 / 120.0, (safe - np.sin(safe)) / safe**3)
    return a, b, c


def so3_exp(w):
    """Rotation vectors (..., 3) -> rotation matrices (..., 3, 3) (Rodrigues)."""
    w = np.asarray(w, dtype=float)
    theta = np.linalg.norm(w, axis=-1)
    a, b, _ = _sinc_terms(theta)
    k = hat(w)
    return np.eye(3) + a[..., None, None] * k + b[..., None, None] * (k @ k)


def so3_log(rotation):
    """Rotation matrices (..., 3, 3) -> rotation vectors (..., 3), angle in [0, pi]."""
    rotation = np.asarray(rotation, dtype=float)
    cos_t = np.clip((np.trace(rotation, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    theta = np.arccos(cos_t)
    skew = vee(rotation)
    sin_t = np.sin(theta)
    near_zero = theta < _SMALL
    near_pi = np.pi - theta < 1e-4
    regular = ~(near_zero | near_pi)
    scale = np.where(regular, theta / np.where(regular, sin_t, 1.0), 1.0 + theta**2 / 6.0)
    out = skew * scale[..., None]
    if np.any(near_pi):
        # Near pi the skew part vanishes; take the axis from the symmetric part instead.
        sym = (rotation[near_pi] + np.swapaxes(rotation[near_pi], -1, -2)) / 2.0
        diag = np.diagonal(sym, axis1=-2, axis2=-1)
        col = np.argmax(diag, axis=-1)
        axis = np.take_along_axis(sym, col[:, None, None], axis=-1)[..., 0]
        axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
        # Fix the sign with the (small) skew part so the result is continuous.
        sign = np.where(np.einsum("...i,...i->...", axis, skew[near_pi]) < 0, -1.0, 1.0)
        out[near_pi] = axis * (sign * theta[near_pi])[..., None]
    return out


def se3_exp(twist):
    """Twists (..., 6) = [v; w] -> transforms (..., 4, 4)."""
    twist = np.asarray(twist, dtype=float)
    v, w = twist[..., :3], twist[..., 3:]
    theta = np.linalg.norm(w, axis=-1)
    a, b, c = _sinc_terms(theta)
    k = hat(w)
    k2 = k @ k
    rot = np.eye(3) + a[..., None, None] * k + b[..., None, None] * k2
    left_jac = np.eye(3) + b[..., None, None] * k + c[..., None, None] * k2
    return make_transform(rot, np.einsum("...ij,...j->...i", left_jac, v))


def se3_log(transform):
    """Transforms (..., 4, 4) -> twists (..., 6) = [v; w]."""
    transform = np.asarray(transform, dtype=float)
    w = so3_log(transform[..., :3, :3])
    theta = np.linalg.norm(w, axis=-1)
    k = hat(w)
    small = theta < _SMALL
    safe = np.where(small, 1.0, theta)
    half = safe / 2.0
    # Inverse of the left Jacobian: I - K/2 + (1/t^2)(1 - (t/2) cot(t/2)) K^2.
    coef = np.where(small, 1.0 / 12.0, (1.0 - half / np.tan(half)) / safe**2)
    inv_left = np.eye(3) - 0.5 * k + coef[..., None, None] * (k @ k)
    v = np.einsum("...ij,...j->...i", inv_left, transform[..., :3, 3])
    return np.concatenate([v, w], axis=-1)


def adjoint(transform):
    """Adjoint (..., 6, 6) of transforms, acting on twists ordered [v; w]."""
    transform = np.asarray(transform, dtype=float)
    rot, pos = transform[..., :3, :3], transform[..., :3, 3]
    out = np.zeros(transform.shape[:-2] + (6, 6))
    out[..., :3, :3] = rot
    out[..., 3:, 3:] = rot
    out[..., :3, 3:] = hat(pos) @ rot
    return out
