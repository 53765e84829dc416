"""The subproblems of :mod:`.subproblems` for one target, on Python floats.

A batch of one pays numpy's per-call cost on every elementwise operation of the closed forms
(some 250 of them: 0.3 ms); the same formulas on floats, one branch after the other, cost a
tenth of that.  Each function mirrors its batched namesake exactly (same formulas, same
special cases) so that a target solved alone gets the batch's branches to rounding.
``dot``, ``cross``, ``matvec``, ``rotate`` and ``rotate_z`` of :mod:`.subproblems` already
work on float triples.  A degenerate case the batch handles through NaN or infinity raises
:class:`Degenerate`; the caller then solves that target as a batch.
"""
import math

ROOT_SIGNS = (1.0, -1.0)


class Degenerate(ArithmeticError):
    """A division by zero or similar that only the batched code handles as the batch does."""


def normalised(cos_part, sin_part):
    norm = math.sqrt(cos_part * cos_part + sin_part * sin_part)
    if norm == 0.0:
        return 1.0, 0.0
    return cos_part / norm, sin_part / norm


def angle_of(cos_part, sin_part):
    if cos_part == 0.0:
        raise Degenerate("angle of a zero cosine part")
    angle = math.atan(sin_part / cos_part)
    return angle + math.copysign(math.pi, sin_part) if cos_part < 0.0 else angle


def sinusoid_roots(a, b, c, free=True):
    """Both roots of a cos x + b sin x = c: ([(angle, cos, sin), (angle, cos, sin)],
    excess), as :func:`.subproblems.sinusoid_roots`; ``free``: a and b vary per target (the
    batch then takes any angle where a, b and c vanish; with constant a, b it does not)."""
    rho = math.sqrt(a * a + b * b)
    if free and rho <= 1e-9 and abs(c) <= 1e-9:
        a, b, rho, c = 1.0, 0.0, 1.0, 0.0
    if rho == 0.0:
        raise Degenerate("sinusoid without amplitude")
    phi = math.atan2(b, a)
    cos_phi, sin_phi = a / rho, b / rho
    excess = abs(c) - rho
    kappa = min(max(c / rho, -1.0), 1.0)
    alpha = math.acos(kappa)
    root = math.sqrt(1.0 - kappa * kappa)
    return [(phi + sign * alpha, cos_phi * kappa - sin_phi * sign * root, sin_phi * kappa + cos_phi * sign * root)
            for sign in ROOT_SIGNS], excess


def angle_about(axis, u, v):
    """(angle, cos, sin) of the rotation about ``axis`` taking ``u`` to ``v``."""
    au = axis[0] * u[0] + axis[1] * u[1] + axis[2] * u[2]
    av = axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2]
    uv = u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
    cx = u[1] * v[2] - u[2] * v[1]
    cy = u[2] * v[0] - u[0] * v[2]
    cz = u[0] * v[1] - u[1] * v[0]
    cos, sin = normalised(uv - au * av, axis[0] * cx + axis[1] * cy + axis[2] * cz)
    return angle_of(cos, sin), cos, sin


class Link:
    """A :class:`.subproblems.TwoLink` with what :func:`planar_two_link` needs, as floats."""

    def __init__(self, link):
        lengths = link.lengths
        self.l_up, self.l_low = float(lengths[0]), float(lengths[1])
        self.ux, self.uy = (float(v) for v in link.upper)
        self.bx, self.by = (float(v) for v in link.base)
        self.bend = float(link.bend)
        self.cos_bend, self.sin_bend = math.cos(self.bend), math.sin(self.bend)


def planar_two_link(link, tx, ty, stretch):
    """Both elbow solutions ([(first, cos_first, sin_first, second, cos_second, sin_second)] * 2,
    excess), as :func:`.subproblems.planar_two_link`."""
    l_up, l_low, ux, uy = link.l_up, link.l_low, link.ux, link.uy
    rx, ry = tx - link.bx, ty - link.by
    reach2 = rx * rx + ry * ry
    kappa = (reach2 - l_up * l_up - l_low * l_low) / (2.0 * l_up * l_low)
    excess = abs(kappa) - 1.0
    kappa = min(max(kappa, -stretch), stretch)
    gamma = math.acos(kappa)
    root = math.sqrt(1.0 - kappa * kappa)
    scale = l_low / l_up
    out = []
    for sign in ROOT_SIGNS:
        sin_gamma = sign * root
        px = ux + scale * (kappa * ux - sin_gamma * uy)
        py = uy + scale * (kappa * uy + sin_gamma * ux)
        cos_first, sin_first = normalised(px * rx + py * ry, px * ry - py * rx)
        out.append((angle_of(cos_first, sin_first), cos_first, sin_first, sign * gamma - link.bend,
                    kappa * link.cos_bend + sin_gamma * link.sin_bend,
                    sin_gamma * link.cos_bend - kappa * link.sin_bend))
    return out, excess


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def matvec(rows, v):
    r0, r1, r2 = rows
    x, y, z = v
    return (r0[0] * x + r0[1] * y + r0[2] * z, r1[0] * x + r1[1] * y + r1[2] * z, r2[0] * x + r2[1] * y + r2[2] * z)


def transposed_matvec(rows, v):
    r0, r1, r2 = rows
    x, y, z = v
    return (r0[0] * x + r1[0] * y + r2[0] * z, r0[1] * x + r1[1] * y + r2[1] * z, r0[2] * x + r1[2] * y + r2[2] * z)


def rotate(axis, c, s, v):
    """Rodrigues' rotation of ``v`` about the unit ``axis`` (as :func:`.subproblems.rotate`)."""
    ax, ay, az = axis
    vx, vy, vz = v
    along = (ax * vx + ay * vy + az * vz) * (1.0 - c)
    return (vx * c + (ay * vz - az * vy) * s + ax * along,
            vy * c + (az * vx - ax * vz) * s + ay * along,
            vz * c + (ax * vy - ay * vx) * s + az * along)


def rotate_z(c, s, v):
    return (c * v[0] - s * v[1], s * v[0] + c * v[1], v[2])
