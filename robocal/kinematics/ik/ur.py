"""Closed-form inverse kinematics of arms with three parallel axes 2, 3, 4 and an offset wrist.

This is the Universal Robots class (UR3/5/10/16/20, and arms built like them); the classic
derivation is Hawkins' for the UR5/UR10 DH parameters.  As for the spherical wrist the
solution works on the screw axes, so joint signs, zero offsets and frames need no special
cases.  The steps, each with two roots (8 branches):

1. Axes 5 and 6 meet in a point W, which the last two joints therefore leave in place.
   Joints 2, 3, 4 turn about parallel axes (direction n) and keep W's component along n: that
   condition gives joint 1 ("shoulder").
2. The same rotations keep n itself: n · R1^T R w6 = n · R5 w6 gives joint 5 ("wrist flip"),
   and R6 (R^T R1 n) = R5^T n gives joint 6 (any value at the singularity where axis 6 is
   parallel to n; the following steps absorb it).
3. What remains, R234 = R1^T R R6^T R5^T, is a rotation about n by t2 + t3 + t4; and a point
   of axis 4 pulled back through joints 6, 5 and 1 is where joints 2 and 3 must carry it, a
   planar two-link problem ("elbow").  Joint 4 takes the rest of the angle.

Branch k = 4 * shoulder + 2 * wrist + elbow, each 0 or 1.
"""
import numpy as np

from . import one
from .closed_form import ClosedForm, _triple, flip_coefficients
from .subproblems import (
    angle_about, angle_of, dot, expand, matvec, planar_two_link, rotate, rotate_z, sinusoid_roots,
    transposed_matvec,
)


class OffsetWrist(ClosedForm):
    """Closed form for axes 2 ∥ 3 ∥ 4 with axes 5 and 6 meeting in a point."""

    kind = "UR-type"

    def _fit(self):
        w = self.axes
        self.sign3 = self._arm_axes()
        self.sign4 = self._parallel(1, 3)
        self._not_parallel(1, 4)
        self._not_parallel(4, 5)
        self.meet = self._meeting_point((4, 5))
        # Joints 2, 3 and 4 keep W's component along their axes; joints 2 and 3 carry
        # axis 4 (the elbow's two links end on it).
        self._fit_arm(self.meet, self.points[3], "axes 2, 3 and 4 are not three distinct parallel axes")
        self.w5, self.w6 = w[4], w[5]
        # n · R5(t) w6 = a cos t + b sin t + offset.
        self.flip = flip_coefficients(self.n, self.w5, self.w6)
        # Axis 4's point relative to W: where joints 5 and 6 move it from.
        self.arm4 = self.points[3] - self.meet

    def _angles(self, rows, t, stretch):
        n = self.n
        ex, ey = self.plane
        # 1. shoulder: n · Rz(-t1) P = n · W with P = G W.
        p, shoulder = self._shoulder(rows, t, self.meet)
        c1, s1 = shoulder.cos, shoulder.sin
        # 2. wrist: joint 5 from n · R5 w6, then joint 6.
        n1 = rotate_z(c1, s1, n)  # R1 n
        a, b, offset = self.flip
        flip = sinusoid_roots(a, b, dot(n1, expand(matvec(rows, self.w6))) - offset)
        c5, s5 = flip.cos, -flip.sin  # R5^T
        back_n = expand(transposed_matvec(rows, n1))  # R^T R1 n
        t6, c6, s6 = angle_about(self.w6, back_n, rotate(self.w5, c5, s5, n))
        s6 = -s6  # R6^T
        # 3. R234 about n: its angle from where it takes the plane's ex.
        c1e, s1e = expand((c1, -s1))  # R1^T, per wrist branch
        swung = rotate_z(c1e, s1e, matvec(rows, rotate(self.w6, c6, s6, rotate(self.w5, c5, s5, ex))))
        phi = angle_of(dot(ex, swung), dot(ey, swung))
        # Axis 4's point pulled back through joints 6, 5 (both about W), then G (which takes
        # W to P) and joint 1.
        moved = matvec(rows, rotate(self.w6, c6, s6, rotate(self.w5, c5, s5, self.arm4)))
        point = rotate_z(c1e, s1e, tuple(m + pi for m, pi in zip(moved, p)))
        elbow = planar_two_link(self.link, (dot(ex, point), dot(ey, point)), stretch)
        shape = elbow.first.shape
        angles = np.stack([
            np.broadcast_to(shoulder.angle[:, None, None, :], shape),
            elbow.first, self.sign3 * elbow.second,
            self.sign4 * (phi[..., None, :] - elbow.first - elbow.second),
            np.broadcast_to(flip.angle[..., None, :], shape),
            np.broadcast_to(t6[..., None, :], shape),
        ])
        return (angles, shoulder.excess[:, None, None, :],
                np.maximum(flip.excess[..., None, :], elbow.excess))

    def _floats(self):
        super()._floats()
        self._f.update(
            sign3=float(self.sign3),
            sign4=float(self.sign4),
            meet=_triple(self.meet),
            w5=_triple(self.w5),
            w6=_triple(self.w6),
            arm4=_triple(self.arm4),
            flip=tuple(float(v) for v in self.flip),
        )

    def _shoulder_roots_one(self, rows, t):
        p, shoulders, shoulder_excess = self._shoulder_one(rows, t, self._f["meet"])
        return (p, one.matvec(rows, self._f["w6"])), shoulders, shoulder_excess

    def _shoulder_angles_one(self, rows, context, shoulder, stretch):
        f = self._f
        n, ex, ey, w5, w6, arm4 = f["n"], f["ex"], f["ey"], f["w5"], f["w6"], f["arm4"]
        a, b, offset = f["flip"]
        p, rows_w6 = context
        t1, c1, s1 = shoulder
        angles, cosine = [], []  # branch by branch, in the order of the batch's axes
        n1 = one.rotate_z(c1, s1, n)
        flips, flip_excess = one.sinusoid_roots(a, b, one.dot(n1, rows_w6) - offset, free=False)
        back_n = one.transposed_matvec(rows, n1)
        for t5, c5, s5 in flips:
            s5 = -s5
            t6, c6, s6 = one.angle_about(w6, back_n, one.rotate(w5, c5, s5, n))
            s6 = -s6
            swung = one.rotate_z(c1, -s1, one.matvec(rows, one.rotate(w6, c6, s6, one.rotate(w5, c5, s5, ex))))
            phi = one.angle_of(one.dot(ex, swung), one.dot(ey, swung))
            moved = one.matvec(rows, one.rotate(w6, c6, s6, one.rotate(w5, c5, s5, arm4)))
            point = one.rotate_z(c1, -s1, (moved[0] + p[0], moved[1] + p[1], moved[2] + p[2]))
            elbows, elbow_excess = one.planar_two_link(f["link"], one.dot(ex, point), one.dot(ey, point), stretch)
            for first, _, _, second, _, _ in elbows:
                angles.append((t1, first, f["sign3"] * second, f["sign4"] * (phi - first - second), t5, t6))
                cosine.append(max(flip_excess, elbow_excess))
        return angles, cosine
