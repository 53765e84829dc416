"""Batched building blocks of the closed-form solvers.

Vectors are held as three separate coordinate arrays ``(x, y, z)`` (or a constant (3,) array,
which indexes the same way), so every operation is a handful of elementwise NumPy calls on
contiguous arrays.  Branches of a solution live on leading axes and targets on the last
axis: a function that splits one value into its two roots inserts a new axis of length 2 just
before the target axis, so shapes grow (N,) -> (2, N) -> (2, 2, N) -> (2, 2, 2, N) and a
value computed at an earlier stage broadcasts against a later one after ``[..., None, :]``.

The three subproblems are those of Paden and Kahan, in the form needed here:

* :func:`sinusoid_roots`   a cos x + b sin x = c   (one angle from one scalar condition)
* :func:`angle_about`      the rotation about an axis that takes one vector to another
* :func:`planar_two_link`  two rotations about parallel axes that bring a point to a target
"""
from typing import NamedTuple

import numpy as np



def dot(a, b):
    """Scalar product of two vectors (coordinate triples or constant (3,) arrays)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    """Vector product."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def matvec(rows, v):
    """A rotation given as three rows of coordinate arrays, applied to a vector."""
    return tuple(dot(row, v) for row in rows)


def transposed_matvec(rows, v):
    """The transpose of a rotation given as rows, applied to a vector."""
    return tuple(rows[0][j] * v[0] + rows[1][j] * v[1] + rows[2][j] * v[2] for j in range(3))


def rotate(axis, c, s, v):
    """Rotate ``v`` about the constant unit ``axis`` by the angle with cosine c and sine s
    (Rodrigues: v c + (axis x v) s + axis (axis . v)(1 - c))."""
    k = cross(axis, v)
    along = dot(axis, v) * (1.0 - c)
    return tuple(v[i] * c + k[i] * s + axis[i] * along for i in range(3))


def rotate_z(c, s, v):
    """Rotate ``v`` about the z axis (the cheap special case of :func:`rotate`)."""
    return (c * v[0] - s * v[1], s * v[0] + c * v[1], v[2])


def expand(v):
    """Insert a branch axis before the target axis so ``v`` broadcasts over a later split."""
    return tuple(x[..., None, :] if np.ndim(x) else x for x in v)


def split(value):
    """``value`` with a new length-2 axis before its last one (scalars pass through)."""
    value = np.asarray(value)
    return value[..., None, :] if value.ndim else value


def normalised(cos_part, sin_part):
    """(cos, sin) of the angle of (cos_part, sin_part) without a trigonometric call; (1, 0)
    for (0, 0), where any angle would do."""
    norm = np.sqrt(cos_part * cos_part + sin_part * sin_part)
    zero = norm == 0.0
    norm = norm + zero
    return (cos_part + zero) / norm, sin_part / norm


def angle_of(cos_part, sin_part):
    """atan2(sin_part, cos_part) for (cos_part, sin_part) not both zero.

    As atan(s / c) plus a half turn where c < 0: one arctan costs less than half an arctan2
    in NumPy, and arctan2 calls are a large share of the closed forms' time.
    """
    with np.errstate(divide="ignore"):
        angle = np.arctan(sin_part / cos_part)
    return angle + np.copysign(np.pi, sin_part) * (cos_part < 0.0)


_ROOT_SIGN = np.array([1.0, -1.0])[:, None]


class Roots(NamedTuple):
    """Two roots of an equation in one angle: angle, its cosine and sine (shape (..., 2, N)),
    and by how much the equation misses having a real solution (<= 0 when it has one;
    shape (..., 1, N))."""

    angle: np.ndarray
    cos: np.ndarray
    sin: np.ndarray
    excess: np.ndarray


def sinusoid_roots(a, b, c):
    """Both solutions x of a cos x + b sin x = c.

    With rho = hypot(a, b) and phi = atan2(b, a) the roots are phi +- acos(c / rho), which
    exist when |c| <= rho; ``excess`` = |c| - rho, in the units of a, b, c (c / rho is clamped
    to [-1, 1], which gives the nearest postures where it is positive).  When a, b and c all
    vanish (to 1e-9) every angle solves the equation; the roots returned are then +-pi/2,
    which are as good as any.  Angles are not wrapped.
    """
    a, b, c = np.broadcast_arrays(a, b, c) if np.ndim(a) else (a, b, c)
    rho = np.sqrt(a * a + b * b)
    if np.ndim(a):
        free = (rho <= 1e-9) & (np.abs(c) <= 1e-9)
        a, b = np.where(free, 1.0, a), np.where(free, 0.0, b)
        rho, c = np.where(free, 1.0, rho), np.where(free, 0.0, c)
    phi = np.arctan2(b, a)
    cos_phi, sin_phi = a / rho, b / rho
    excess = np.abs(c) - rho
    kappa = np.clip(c / rho, -1.0, 1.0)
    alpha = split(np.arccos(kappa)) * _ROOT_SIGN
    kappa, root = split(kappa), split(np.sqrt(1.0 - kappa * kappa)) * _ROOT_SIGN
    cos_phi, sin_phi = split(cos_phi), split(sin_phi)
    angle = split(phi) + alpha
    # cos and sin of phi +- alpha without further trigonometric calls.
    cos = cos_phi * kappa - sin_phi * root
    sin = sin_phi * kappa + cos_phi * root
    return Roots(angle, cos, sin, split(excess))


def angle_about(axis, u, v):
    """The rotation about the constant unit ``axis`` that takes ``u`` to ``v`` (both vectors
    projected onto the plane normal to the axis): its angle, cosine and sine.

    When either projection vanishes every angle is a solution and the result is arbitrary;
    the solvers compute the following joint from the full remaining rotation so that such an
    arbitrary choice still gives an exact pose.
    """
    cos, sin = normalised(dot(u, v) - dot(axis, u) * dot(axis, v), dot(axis, cross(u, v)))
    return angle_of(cos, sin), cos, sin


class TwoLink(NamedTuple):
    """Geometry of two rotations about parallel axes, in 2-D coordinates of the plane normal
    to them: the first axis at ``base``; the vector ``upper`` from it to the second axis and
    ``lower`` from there to the point moved, at zero angles."""

    base: np.ndarray
    upper: np.ndarray
    lower: np.ndarray

    @property
    def lengths(self):
        return np.hypot(*self.upper), np.hypot(*self.lower)

    @property
    def bend(self):
        """Angle from ``upper`` to ``lower`` at zero angles."""
        (ux, uy), (lx, ly) = self.upper, self.lower
        return np.arctan2(ux * ly - uy * lx, ux * lx + uy * ly)


class Planar(NamedTuple):
    """Both solutions of :func:`planar_two_link`, each (..., 2, N): angles of the first and
    second rotation with their cosines and sines; and by how much the target is out of reach,
    as |cos| - 1 of the angle between the links (<= 0 within reach; shape (..., 1, N))."""

    first: np.ndarray
    cos_first: np.ndarray
    sin_first: np.ndarray
    second: np.ndarray
    cos_second: np.ndarray
    sin_second: np.ndarray
    excess: np.ndarray


def planar_two_link(link, target, stretch=1.0):
    """The two rotations that take the moved point to ``target`` (2-D coordinates (tx, ty)),
    both elbow solutions; angles counter-clockwise in the plane's coordinates, not wrapped.

    The law of cosines gives the second rotation (the angle between the links), and the first
    is then the angle from where the point would be to where it must go.  Out of reach, the
    links are stretched (or folded) towards the target, up to |cos| = ``stretch`` of the
    angle between them.
    """
    l_up, l_low = link.lengths
    ux, uy = link.upper
    bend = link.bend
    rx, ry = target[0] - link.base[0], target[1] - link.base[1]
    reach2 = rx * rx + ry * ry
    kappa = (reach2 - l_up * l_up - l_low * l_low) / (2.0 * l_up * l_low)
    excess = np.abs(kappa) - 1.0
    kappa = np.clip(kappa, -stretch, stretch)
    # gamma = angle between the links after the second rotation: cos gamma = kappa.
    gamma = split(np.arccos(kappa)) * _ROOT_SIGN
    sin_gamma = split(np.sqrt(1.0 - kappa * kappa)) * _ROOT_SIGN
    kappa, rx, ry, reach2 = split(kappa), split(rx), split(ry), split(reach2)
    # Where the point is after the second rotation, relative to the first axis:
    # upper + (l_low / l_up) * Rot(gamma) upper.
    scale = l_low / l_up
    px = ux + scale * (kappa * ux - sin_gamma * uy)
    py = uy + scale * (kappa * uy + sin_gamma * ux)
    cos_first, sin_first = normalised(px * rx + py * ry, px * ry - py * rx)
    cos_bend, sin_bend = np.cos(bend), np.sin(bend)
    return Planar(
        angle_of(cos_first, sin_first), cos_first, sin_first,
        gamma - bend, kappa * cos_bend + sin_gamma * sin_bend, sin_gamma * cos_bend - kappa * sin_bend,
        split(excess),
    )
