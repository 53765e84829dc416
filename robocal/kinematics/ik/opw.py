"""Closed-form inverse kinematics of arms with parallel axes 2 and 3 and a spherical wrist.

This is the class of most industrial six-axis robots (KUKA, ABB, FANUC, Yaskawa...), the
"ortho-parallel basis with a spherical wrist" of Brandstötter, Angerer and Hofbaur (2014).
Instead of their seven OPW lengths the solution here works on the screw axes themselves, which
removes every convention question (joint signs, zero offsets, DH or MDH, where the base and
flange frames are) and also covers axis 1 not perpendicular to axis 2 and non-orthogonal wrist
axes.  The steps, each with two roots (8 branches):

1. The wrist centre c (where axes 4, 5, 6 meet) is fixed by the target.  Joints 2 and 3 turn
   about parallel axes, so they keep c's component along them: that one scalar condition
   gives joint 1 (:func:`sinusoid_roots`, "shoulder").
2. Joints 2 and 3 then bring c to the target in the plane normal to their axes
   (:func:`planar_two_link`, "elbow").
3. The wrist's rotation R456 follows; w4 · R456 w6 depends on joint 5 alone ("wrist flip"),
   joint 4 turns R5 w6 onto R456 w6, and joint 6 is whatever rotation remains, which keeps the
   pose exact even at the wrist singularity, where joints 4 and 6 share one angle.  For the
   usual orthogonal wrist the second flip is the first with joints 4 and 6 turned by pi.

Branch k = 4 * shoulder + 2 * elbow + wrist, each 0 or 1.
"""
import numpy as np

from . import one
from .closed_form import ClosedForm, _triple, flip_coefficients, plane_basis
from .subproblems import (
    angle_about, angle_of, dot, expand, matvec, planar_two_link, rotate, rotate_z, sinusoid_roots,
)


class SphericalWrist(ClosedForm):
    """Closed form for axes 2 ∥ 3 and axes 4, 5, 6 meeting in a point."""

    kind = "spherical-wrist"

    def _fit(self):
        w = self.axes
        self.sign3 = self._arm_axes()
        self._not_parallel(3, 4)
        self._not_parallel(4, 5)
        self.centre = self._meeting_point((3, 4, 5))
        # Joints 2 and 3 keep the wrist centre's component along their axes, and carry the
        # centre itself (the elbow's two links end there).
        self._fit_arm(self.centre, self.centre,
                      "axes 2 and 3 coincide or axis 3 passes through the wrist centre")
        w4, w5, w6 = w[3], w[4], w[5]
        self.w4, self.w5, self.w6 = w4, w5, w6
        # w4 · R5(t) w6 = a cos t + b sin t + offset.
        self.flip = flip_coefficients(w4, w5, w6)
        # With axes 4 and 6 perpendicular to 5 (every industrial wrist), the two wrist
        # solutions are mirror images: (t4, t5, t6) and (t4 + pi, t5', t6 + pi).
        self.orthogonal = self._perpendicular((3, 4), (4, 5))
        self.x6, _ = plane_basis(w6)
        self.y6 = np.cross(w6, self.x6)

    def _angles(self, rows, t, stretch):
        n = self.n
        # 1. shoulder: n · Rz(-t1) c = n · c0 with c the wrist centre of the target.
        c, shoulder = self._shoulder(rows, t, self.centre)
        c1, s1 = shoulder.cos, -shoulder.sin  # undo joint 1
        # 2. elbow: joints 2 and 3 in the plane normal to their axes.
        centre = rotate_z(c1, s1, expand(c))
        ex, ey = self.plane
        elbow = planar_two_link(self.link, (dot(ex, centre), dot(ey, centre)), stretch)
        # R23^T: undo the rotation by t2 + psi about n.
        c23 = elbow.cos_first * elbow.cos_second - elbow.sin_first * elbow.sin_second
        s23 = -(elbow.sin_first * elbow.cos_second + elbow.cos_first * elbow.sin_second)
        # 3. wrist: R456 w6 and R456 x6 from R123^T R.
        r_w6 = rotate(n, c23, s23, expand(rotate_z(c1, s1, expand(matvec(rows, self.w6)))))
        r_x6 = rotate(n, c23, s23, expand(rotate_z(c1, s1, expand(matvec(rows, self.x6)))))
        a, b, offset = self.flip
        flip = sinusoid_roots(a, b, dot(self.w4, r_w6) - offset)
        r_w6, r_x6 = expand(r_w6), expand(r_x6)
        c5, s5 = flip.cos, flip.sin
        if self.orthogonal:
            # Half the work: the second flip root is the first's mirror, reached with
            # joints 4 and 6 each half a turn further.
            c5, s5 = c5[..., :1, :], s5[..., :1, :]
        t4, c4, s4 = angle_about(self.w4, rotate(self.w5, c5, s5, self.w6), r_w6)
        # Joint 6 is the rotation left: R6 x6 = R5^T R4^T (R456 x6).
        rest = rotate(self.w5, c5, -s5, rotate(self.w4, c4, -s4, r_x6))
        t6 = angle_of(dot(self.x6, rest), dot(self.y6, rest))
        if self.orthogonal:
            t4 = np.concatenate([t4, t4 + np.pi], axis=-2)
            t6 = np.concatenate([t6, t6 + np.pi], axis=-2)
        shape = t4.shape
        angles = np.stack([
            np.broadcast_to(shoulder.angle[:, None, None, :], shape),
            np.broadcast_to(elbow.first[:, :, None, :], shape),
            np.broadcast_to(self.sign3 * elbow.second[:, :, None, :], shape),
            t4, flip.angle, t6,
        ])
        return (angles, shoulder.excess[:, None, None, :],
                np.maximum(elbow.excess[:, :, None, :], flip.excess))

    def _floats(self):
        super()._floats()
        self._f.update(
            sign3=float(self.sign3),
            centre=_triple(self.centre),
            w4=_triple(self.w4),
            w5=_triple(self.w5),
            w6=_triple(self.w6),
            x6=_triple(self.x6),
            y6=_triple(self.y6),
            flip=tuple(float(v) for v in self.flip),
        )

    def _shoulder_roots_one(self, rows, t):
        f = self._f
        c, shoulders, shoulder_excess = self._shoulder_one(rows, t, f["centre"])
        return (c, one.matvec(rows, f["w6"]), one.matvec(rows, f["x6"])), shoulders, shoulder_excess

    def _shoulder_angles_one(self, rows, context, shoulder, stretch):
        f = self._f
        n, ex, ey, w4, w5, w6, x6, y6 = (f[k] for k in ("n", "ex", "ey", "w4", "w5", "w6", "x6", "y6"))
        a, b, offset = f["flip"]
        c, rows_w6, rows_x6 = context
        angles, cosine = [], []  # branch by branch, in the order of the batch's axes

        def wrist(c5, s5, r_w6, r_x6):
            t4, c4, s4 = one.angle_about(w4, one.rotate(w5, c5, s5, w6), r_w6)
            rest = one.rotate(w5, c5, -s5, one.rotate(w4, c4, -s4, r_x6))
            return t4, one.angle_of(one.dot(x6, rest), one.dot(y6, rest))

        t1, c1, s1 = shoulder
        s1 = -s1  # undo joint 1
        centre = one.rotate_z(c1, s1, c)
        elbows, elbow_excess = one.planar_two_link(f["link"], one.dot(ex, centre), one.dot(ey, centre), stretch)
        w6_1, x6_1 = one.rotate_z(c1, s1, rows_w6), one.rotate_z(c1, s1, rows_x6)
        for first, cf, sf, second, cs, ss in elbows:
            c23 = cf * cs - sf * ss
            s23 = -(sf * cs + cf * ss)
            r_w6, r_x6 = one.rotate(n, c23, s23, w6_1), one.rotate(n, c23, s23, x6_1)
            flips, flip_excess = one.sinusoid_roots(a, b, one.dot(w4, r_w6) - offset, free=False)
            if self.orthogonal:
                # As the batch: the second root is the first's mirror.
                t4, t6 = wrist(flips[0][1], flips[0][2], r_w6, r_x6)
                wrists = ((t4, t6), (t4 + np.pi, t6 + np.pi))
            else:
                wrists = tuple(wrist(c5, s5, r_w6, r_x6) for _, c5, s5 in flips)
            for j, (t4, t6) in enumerate(wrists):
                angles.append((t1, first, f["sign3"] * second, t4, flips[j][0], t6))
                cosine.append(max(elbow_excess, flip_excess))
        return angles, cosine
