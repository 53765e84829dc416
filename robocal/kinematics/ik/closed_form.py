"""What the closed-form solvers share.

A 6R chain is T(q) = base · E1(t1) ⋯ E6(t6) · home · tool, where Ei is the screw motion about
joint i's axis (direction w_i through point p_i, from :func:`to_poe`) and t = q_model + theta
is the exponential angle.  A solver therefore works on G = E1 ⋯ E6 = base⁻¹ · T · (home · tool)⁻¹
and returns the angles t; this module turns them into controller joints (offsets, joint map)
and does the bookkeeping around the geometry:

* the axes are re-expressed in a working frame whose z axis is joint 1's axis and whose origin
  lies on it, so undoing joint 1 is a plain rotation about z;
* each structural condition a solver relies on (axes parallel, axes meeting in a point) is
  measured.  A chain that meets them within rounding is solved exactly; one that meets them
  only approximately (a calibrated robot) is solved on an idealised geometry — the result is
  then a seed that the numerical solver refines; one that does not meet them at all raises
  :class:`NoFit` with the reason.
"""
import math

import numpy as np

from ...errors import InputError
from ...spatial import invert, make_transform, rot_y, rot_z
from ..conversions import to_poe
from . import one
from .limits import INVERSE_TWO_PI, LIMIT_TOL, TWO_PI, nearest_equivalent, periodic_joints
from .subproblems import TwoLink, matvec, sinusoid_roots

# Deviations from the ideal structure below these count as rounding: the solution is exact.
EXACT_SINE = 1e-12
EXACT_LENGTH = 1e-9  # mm
# Deviations up to these still give seeds well inside the numerical solver's reach
# (calibrated robots deviate by fractions of a degree and a few millimetres).
FIT_SINE = 0.05  # about 2.9 degrees
FIT_LENGTH = 20.0  # mm
# How far out of reach a target may be (in mm for conditions on lengths, dimensionless for
# cosines) and still count as reached: rounding for exact solutions; far more for seeds of a
# slightly different chain, where a target just out of reach of the idealised robot may be
# within reach of the real one and the nearest idealised posture (the stretched arm) is then
# a good seed.  Seeds may likewise lie a little beyond a joint limit (rad).
EXACT_REACH = (1e-9, 1e-12)
SEED_REACH = (50.0, 0.1)
SEED_MARGIN = 0.2
# A seed on the stretched-arm singularity stalls the numerical solver (its Jacobian has no
# component along the reach), so seeds keep the elbow bent by a few degrees at least.
SEED_STRETCH = 1.0 - 1e-3
# Axes closer to parallel than this cannot define an angle between them.
MIN_SINE = 0.1
# What branches_one returns for a branch that is not usable.
_NANS = (float("nan"),) * 6
_ZEROS = (0.0,) * 6
# Targets per block: the temporaries of one block stay in the processor's cache.
BLOCK = 4096
# Up to this many targets, G comes from plain 4x4 products (see ClosedForm._relative).
FEW = 8


class NoFit(InputError):
    """The chain does not have the structure a solver needs; the message says why."""


def _unit(v):
    return v / np.linalg.norm(v)


def _sine(u, v):
    return float(np.linalg.norm(np.cross(u, v)))


def plane_basis(normal):
    """Two unit vectors spanning the plane normal to ``normal``, right-handed with it."""
    helper = np.eye(3)[np.argmin(np.abs(normal))]
    ex = _unit(np.cross(helper, normal))
    return ex, np.cross(normal, ex)


def check_joints(chain):
    """Raise :class:`NoFit` unless the chain has the six revolute joints closed forms need."""
    if chain.n_joints != 6 or not np.all(chain.revolute):
        raise NoFit(f"closed forms need 6 revolute joints; robot {chain.name!r} has "
                    f"{chain.n_joints} ({', '.join(sorted(set(chain.joint_types)))})")
    if abs(np.linalg.det(chain.joint_map)) < 1e-12:
        raise NoFit(f"robot {chain.name!r} has a singular joint map")


class ClosedForm:
    """Base of the closed-form solvers.  Subclasses set :attr:`kind`, check and idealise the
    geometry in :meth:`_fit`, and compute the exponential angles of all 8 branches in
    :meth:`_angles`."""

    kind = ""

    def __init__(self, chain):
        check_joints(chain)
        poe = to_poe(chain)
        # Working frame: z along joint 1's axis, origin on it, x towards joint 2's axis
        # direction where that is defined.
        w1 = poe.axes[0]
        helper = poe.axes[1] - (poe.axes[1] @ w1) * w1
        if np.linalg.norm(helper) < MIN_SINE:
            helper = np.eye(3)[np.argmin(np.abs(w1))]
        x = _unit(helper - (helper @ w1) * w1)
        frame = make_transform(np.column_stack([x, np.cross(w1, x), w1]), poe.points[0])
        rot = frame[:3, :3]
        self.axes = poe.axes @ rot
        self.axes[0] = (0.0, 0.0, 1.0)
        self.points = (poe.points - poe.points[0]) @ rot
        self._pre = invert(frame) @ invert(chain.base)
        self._post = invert(poe.home @ chain.tool) @ frame
        self._offsets = poe.theta
        self._unmap = np.linalg.inv(chain.joint_map)
        self._periodic = periodic_joints(chain)[:, None, None]
        self._lower = chain.lower[:, None, None] - LIMIT_TOL
        self._upper = chain.upper[:, None, None] + LIMIT_TOL
        self._worst_sine = 0.0
        self._worst_length = 0.0
        self._fit()
        self._floats()
        self._point_constants()

    def _floats(self):
        """The constants of :meth:`_angles_one` as floats (subclasses add their own)."""
        self._f = {"n": _triple(self.n), "ex": _triple(self.plane[0]), "ey": _triple(self.plane[1]),
                   "link": one.Link(self.link), "along": float(self.along)}

    def _point_constants(self):
        """What :meth:`branches_one` needs as Python floats: offsets, the joint map's inverse
        as the nonzero terms of each row (None for the identity), periodic joints, and the
        limits (with :data:`LIMIT_TOL`, and widened by :data:`SEED_MARGIN` for seeds)
        computed as the batch computes them, so that the masks agree to the bit."""
        # x - 0.0 is x: zero offsets are left out.
        self._offsets_f = None if not np.any(self._offsets) else [float(v) for v in self._offsets]
        unmap = self._unmap
        self._unmap_terms = None if np.array_equal(unmap, np.eye(6)) else [
            [(j, float(c)) for j, c in enumerate(row) if c != 0.0] for row in unmap]
        # Joint 1's row of a diagonal joint map (for the bound of :meth:`nearest_one`).
        diagonal = np.count_nonzero(unmap - np.diag(np.diag(unmap))) == 0
        self._diagonal_terms = [(0, float(unmap[0, 0]))] if diagonal else None
        periodic = [bool(v) for v in self._periodic[:, 0, 0]]
        lower, upper = self._lower[:, 0, 0], self._upper[:, 0, 0]
        # Per joint: the limits (widened for seeds), the limits without margin, periodic.
        self._joint_limits_f = {
            seeds: list(zip((lower - margin).tolist(), (upper + margin).tolist(), lower.tolist(),
                            upper.tolist(), periodic))
            for seeds, margin in ((False, 0.0), (True, SEED_MARGIN))}

    @property
    def exact(self):
        """True when the chain has the solver's structure to rounding: solutions are exact."""
        return self._worst_sine <= EXACT_SINE and self._worst_length <= EXACT_LENGTH

    # ----------------------------------------------------------- structure checks
    def _parallel(self, i, j):
        """Sign (+1 / -1) relating parallel axes i and j (0-based); raises NoFit if they are not."""
        sine = _sine(self.axes[i], self.axes[j])
        if sine > FIT_SINE:
            raise NoFit(f"axes {i + 1} and {j + 1} are not parallel "
                        f"({np.degrees(np.arcsin(min(sine, 1.0))):.1f} deg apart)")
        self._worst_sine = max(self._worst_sine, sine)
        return 1.0 if self.axes[i] @ self.axes[j] > 0 else -1.0

    def _not_parallel(self, i, j):
        if _sine(self.axes[i], self.axes[j]) < MIN_SINE:
            raise NoFit(f"axes {i + 1} and {j + 1} are (nearly) parallel")

    def _perpendicular(self, *pairs):
        """Whether the axes of every pair (i, j) are perpendicular, within the fit tolerance;
        if so, a solver that relies on it carries the deviation."""
        cosine = max(abs(float(self.axes[i] @ self.axes[j])) for i, j in pairs)
        if cosine > FIT_SINE:
            return False
        self._worst_sine = max(self._worst_sine, cosine)
        return True

    def _meeting_point(self, indices):
        """The point nearest (least squares) to the given axes; raises NoFit if they do not meet."""
        projectors = [np.eye(3) - np.outer(self.axes[i], self.axes[i]) for i in indices]
        point = np.linalg.solve(sum(projectors), sum(P @ self.points[i] for P, i in zip(projectors, indices)))
        gap = max(np.linalg.norm(P @ (point - self.points[i])) for P, i in zip(projectors, indices))
        names = ", ".join(str(i + 1) for i in indices[:-1]) + f" and {indices[-1] + 1}"
        if gap > FIT_LENGTH:
            raise NoFit(f"axes {names} do not meet ({gap:.1f} mm from a common point)")
        self._worst_length = max(self._worst_length, gap)
        return point

    def _plane_points(self, basis, *points):
        """2-D coordinates of points in the plane spanned by ``basis``."""
        return [np.array([basis[0] @ p, basis[1] @ p]) for p in points]

    # --------------------------------------- shoulder and elbow (both solvers share them)
    def _arm_axes(self):
        """Check the axes the shoulder and elbow need: axis 1 not parallel to axis 2 (else
        joint 1 could not move the arm's plane), axis 3 parallel to axis 2.  Returns the sign
        relating axes 2 and 3 (see :meth:`_parallel`).  Each solver's :meth:`_fit` calls it
        first: of several failed checks, the first raised is the one reported."""
        self._not_parallel(0, 1)
        return self._parallel(1, 2)

    def _fit_arm(self, kept, reached, why):
        """Fit the shoulder and elbow common to both solvers, where joints 2 and 3 (and any
        joint parallel to them) turn about parallel axes of direction n = axis 2.

        ``kept`` (3,), mm, working frame: a point that those parallel joints move in the
        plane normal to n, so its component along n (:attr:`along`) fixes joint 1 alone.
        ``reached`` (3,), mm: the point that joints 2 and 3 carry; the links from axis 2 to
        axis 3 and from axis 3 to that point form :attr:`link`, in 2-D coordinates of
        :attr:`plane` (two unit vectors (3,) spanning the plane normal to n).  Raises
        :class:`NoFit` with ``why`` when a link is shorter than 1 mm: the two-link problem
        would then have no unique solution.
        """
        n = self.axes[1]
        self.n = n
        self.along = n @ kept
        self.plane = plane_basis(n)
        p2, p3, end = self._plane_points(self.plane, self.points[1], self.points[2], reached)
        self.link = TwoLink(p2, p3 - p2, end - p3)
        if min(self.link.lengths) < 1.0:
            raise NoFit(why)

    def _shoulder(self, rows, t, kept):
        """Joint 1 for a block of B targets, from the point ``kept`` given to :meth:`_fit_arm`.

        ``rows`` and ``t``: G as from :meth:`_relative`.  Joints 2.. keep n · p for the point
        p = G · kept (coordinate arrays (B,), mm), so n · Rz(-t1) p = :attr:`along`, one
        sinusoid condition.  Returns p and the :class:`~.subproblems.Roots` of t1 (2, B).
        """
        n = self.n
        p = tuple(pi + ti for pi, ti in zip(matvec(rows, kept), t))
        roots = sinusoid_roots(n[0] * p[0] + n[1] * p[1], n[0] * p[1] - n[1] * p[0],
                               self.along - n[2] * p[2])
        return p, roots

    def _shoulder_one(self, rows, t, kept):
        """:meth:`_shoulder` for one target (``rows``, ``t`` and ``kept`` float triples):
        (p, the two roots of t1, their excess); see :mod:`.one`."""
        n = self._f["n"]
        moved = one.matvec(rows, kept)
        p = (moved[0] + t[0], moved[1] + t[1], moved[2] + t[2])
        roots, excess = one.sinusoid_roots(n[0] * p[0] + n[1] * p[1], n[0] * p[1] - n[1] * p[0],
                                           self._f["along"] - n[2] * p[2])
        return p, roots, excess

    def _fit(self):
        raise NotImplementedError

    def _shoulder_roots_one(self, rows, t):
        """The first step of :meth:`_angles_one`: (what the second needs, the two roots
        (angle, cos, sin) of joint 1's exponential angle, the length excess: one float, the
        same for every branch); ``rows`` and ``t``, G's rotation rows and translation as
        float triples."""
        raise NotImplementedError

    def _shoulder_angles_one(self, rows, context, shoulder, stretch):
        """The four branches of one shoulder root (from :meth:`_shoulder_roots_one`): their
        exponential angles (4 tuples of 6, in the batch's order) and cosine excesses (4
        floats), on floats (raises :class:`.one.Degenerate` where only the batched code can
        follow the batch)."""
        raise NotImplementedError

    def _angles_one(self, rows, t, stretch):
        """:meth:`_angles` for one target, G's rows and translation as float triples: the
        exponential angles of the 8 branches (8 tuples of 6, in the order of the batch's
        flattened branch axes), the length excess (one float) and the cosine excesses (8
        floats)."""
        context, shoulders, length = self._shoulder_roots_one(rows, t)
        angles, cosine = [], []
        for shoulder in shoulders:
            more, more_cosine = self._shoulder_angles_one(rows, context, shoulder, stretch)
            angles += more
            cosine += more_cosine
        return angles, length, cosine

    def _angles(self, rows, t, stretch):
        """Exponential angles (6, 2, 2, 2, B) of every branch, for G given as rotation rows
        and translation, and how far out of reach each branch is: in mm and as a cosine
        excess (both <= 0 within reach; broadcastable to (2, 2, 2, B)).  ``stretch``: the
        largest |cos| of the elbow angle (see :func:`planar_two_link`)."""
        raise NotImplementedError

    # ---------------------------------------------------------------------- solve
    def _relative(self, targets):
        """Rows of the rotation and the translation of G = pre · T · post for a block of
        targets, as coordinate arrays (constant factors multiplied out per coordinate:
        batched 4x4 matrix products are several times slower, except for a few targets,
        where the thirty-odd array operations below cost far more than two products)."""
        if targets.shape[0] <= FEW:
            g = self._pre @ targets @ self._post
            return (tuple(tuple(g[:, i, j] for j in range(3)) for i in range(3)),
                    tuple(g[:, i, 3] for i in range(3)))
        comps = np.ascontiguousarray(targets[:, :3, :].transpose(1, 2, 0))  # (3, 4, B)
        pre, post = self._pre, self._post
        # M = T · post, then G = pre · M.
        m = [[_combine(post[:3, j], comps[i, :3]) for j in range(4)] for i in range(3)]
        for i in range(3):
            m[i][3] = m[i][3] + comps[i, 3]
        rows = tuple(tuple(_combine(pre[i, :3], [m[k][j] for k in range(3)]) for j in range(3))
                     for i in range(3))
        t = tuple(_combine(pre[i, :3], [m[k][3] for k in range(3)]) + pre[i, 3] for i in range(3))
        return rows, t

    def facing(self, positions, poses, tilt=0.0):
        """Poses (N, 4, 4) for seeding position-only problems: ``poses`` tilted by ``tilt``
        about the horizontal (normal to axis 1 and to the radial direction) and turned about
        axis 1 until they face ``positions`` (N, 3), then moved there.  With no tilt the arm
        keeps its posture relative to the target, so the pose is usually within reach where
        the position is; tilts of +-pi/2 and pi point the tool down, up or back instead."""
        local = lambda p: p @ self._pre[:3, :3].T + self._pre[:3, 3]  # noqa: E731
        target, current = local(positions), local(poses[:, :3, 3])
        azimuth = np.arctan2(target[:, 1], target[:, 0])
        own = np.arctan2(current[:, 1], current[:, 0])
        turn = rot_z(azimuth) @ rot_y(tilt) @ rot_z(-own)
        to_world = invert(self._pre)[:3, :3]
        return make_transform(to_world @ turn @ self._pre[:3, :3] @ poses[:, :3, :3], positions)

    def solve(self, targets, reference=None):
        """Every branch for (N, 4, 4) TCP targets in the world frame.

        Returns controller joints q (N, 8, 6) and a mask valid (N, 8) of the branches that
        exist within the joint limits; the other branches are NaN.  Periodic joints take the
        2 pi equivalent nearest ``reference`` ((N, 6) or (6,); default zero) that fits the
        limits.  With an inexact fit (see :attr:`exact`) use :meth:`seeds` instead.
        """
        q, valid, _ = self._branches(targets, reference, seeds=False)
        return q, valid

    def seeds(self, targets, reference=None):
        """Branches as seeds for a numerical solver on a chain slightly different from the
        one this solver fits exactly: q (N, 8, 6), usable (N, 8) — allowing targets a little
        out of reach and joints a little beyond their limits — and preferred (N, 8), the
        usable branches that need neither allowance.
        """
        return self._branches(targets, reference, seeds=True)

    def _branches(self, targets, reference, seeds):
        targets = np.asarray(targets, dtype=float).reshape(-1, 4, 4)
        count = targets.shape[0]
        if count == 1:
            try:
                return self._branches_one(targets[0], reference, seeds)
            except one.Degenerate:
                pass
        margin = SEED_MARGIN if seeds else 0.0
        q = np.empty((count, 8, 6))
        usable = np.empty((count, 8), dtype=bool)
        preferred = np.empty((count, 8), dtype=bool)
        for start in range(0, count, BLOCK):
            block = slice(start, min(start + BLOCK, count))
            angles, length_excess, cosine_excess = self._block_angles(targets[block], SEED_STRETCH if seeds else 1.0)
            joints = self._controller_joints(angles.reshape(6, 8, -1))
            near = 0.0 if reference is None else np.broadcast_to(reference, (count, 6))[block].T[:, None, :]
            joints, inside = nearest_equivalent(joints, near, self._lower - margin,
                                                self._upper + margin, self._periodic)
            exact = _reach(length_excess, cosine_excess, EXACT_REACH)
            if seeds:
                ok = _reach(length_excess, cosine_excess, SEED_REACH) & np.all(inside, axis=0)
                best = exact & np.all((joints >= self._lower) & (joints <= self._upper), axis=0)
            else:
                ok = best = exact & np.all(inside, axis=0)
            joints += np.where(ok, 0.0, np.nan)  # (8, B) mask, cheaper than indexing (6, 8, B)
            # Transposing (6, 8, B) to (B, 8, 6) one column at a time is the fastest way here.
            out = q[block]
            for j in range(6):
                for k in range(8):
                    out[:, k, j] = joints[j, k]
            usable[block], preferred[block] = ok.T, best.T
        return q, usable, preferred

    def _block_angles(self, targets, stretch):
        """:meth:`_angles` of a block of targets (N, 4, 4)."""
        return self._angles(*self._relative(targets), stretch)

    def _branches_one(self, target, reference, seeds):
        """:meth:`_branches` of one target (4, 4), from :meth:`branches_one` (raises
        :class:`.one.Degenerate` where that cannot follow the batch)."""
        near = None if reference is None else np.broadcast_to(reference, (1, 6))[0].tolist()
        joints, usable, preferred = self.branches_one(target, near, seeds)
        return np.array(joints)[None], np.array(usable)[None], np.array(preferred)[None]

    def branches_one(self, target, reference, seeds):
        """Every branch of one target, on Python floats: what :meth:`solve` (``seeds``
        False) or :meth:`seeds` returns for it, as lists.

        target: (4, 4) array, world frame (mm); reference: 6 floats (rad) or None (zero).
        Returns joints (8 lists of 6 floats, NaN where not usable), usable (8 bools) and
        preferred (8 bools).  The same formulas and order of operations as the batch, so
        the same branches to rounding and the same masks; raises :class:`.one.Degenerate`
        where only the batch can follow the batch (a target that is not finite, a division
        by zero).
        """
        rows, t = self._relative_one(target)
        angles, length, cosine = self._angles_one(rows, t, SEED_STRETCH if seeds else 1.0)
        near = reference if reference is not None else _ZEROS
        found = [self._branch_one(branch, branch_cosine, length, near, seeds)
                 for branch, branch_cosine in zip(angles, cosine)]
        return [f[0] for f in found], [f[1] for f in found], [f[2] for f in found]

    def nearest_one(self, target, reference, seeds, allowance):
        """The usable branch of one target nearest ``reference`` (6 floats, rad), as
        :func:`~.solve.solve_ik` ranks them: squared joint distance, plus ``allowance`` for
        a branch that is not preferred, the first of equals.  Returns (joints (6 floats),
        preferred) or None when no branch is usable; raises :class:`.one.Degenerate` as
        :meth:`branches_one` does.

        With a diagonal joint map, joint 1 alone bounds the distance of a shoulder root's
        four branches from below, so the shoulder root whose joint 1 is farther is solved
        only if that bound does not exceed the best branch of the nearer one (it rarely
        does: the two roots are about half a turn apart), and not at all when joint 1
        cannot be brought within its limits.
        """
        rows, t = self._relative_one(target)
        context, shoulders, length = self._shoulder_roots_one(rows, t)
        stretch = SEED_STRETCH if seeds else 1.0
        order = sorted((self._joint1_bound(shoulder[0], reference, seeds), k) for k, shoulder in enumerate(shoulders))
        best, found = (math.inf, 8), None
        for bound, k in order:
            if bound > best[0]:
                break
            angles, cosine = self._shoulder_angles_one(rows, context, shoulders[k], stretch)
            for j, (branch, branch_cosine) in enumerate(zip(angles, cosine)):
                joints, ok, clean = self._branch_one(branch, branch_cosine, length, reference, seeds)
                if not ok:
                    continue
                distance = sum([(b - r) ** 2 for b, r in zip(joints, reference)])
                if not clean:
                    distance += allowance
                key = (distance, 4 * k + j)
                if key < best:
                    best, found = key, (joints, clean)
        return found

    def _relative_one(self, target):
        """G of one target (4, 4) as float triples (rotation rows, translation)."""
        g = (self._pre @ target @ self._post).tolist()
        r0, r1, r2 = g[0], g[1], g[2]
        if not math.isfinite(sum(r0) + sum(r1) + sum(r2)):
            raise one.Degenerate("a target that is not finite")
        return ((r0[0], r0[1], r0[2]), (r1[0], r1[1], r1[2]), (r2[0], r2[1], r2[2])), (r0[3], r1[3], r2[3])

    def _joint1_bound(self, angle, reference, seeds):
        """(joint 1 - reference)^2 of every branch with joint 1's exponential angle
        ``angle``: a lower bound of their squared distance; infinite when joint 1 cannot be
        within its limits, 0 when the joint map mixes joint 1 with others."""
        if self._diagonal_terms is None:
            return 0.0
        value = angle if self._offsets_f is None else angle - self._offsets_f[0]
        value = _combine_one(self._diagonal_terms, [value])
        low, high, _, _, turns = self._joint_limits_f[seeds][0]
        try:
            if turns:
                value = value + TWO_PI * round((reference[0] - value) * INVERSE_TWO_PI)
                if value < low:
                    value += TWO_PI
                if value > high:
                    value -= TWO_PI
        except (ValueError, OverflowError):
            raise one.Degenerate("an angle that is not finite") from None
        if not low <= value <= high:
            return math.inf
        return (value - reference[0]) ** 2

    def _branch_one(self, branch, branch_cosine, length, near, seeds):
        """One branch's controller joints (6 floats, NaN unless usable), usable, preferred,
        from its exponential angles and excesses, as :meth:`_branches` computes them."""
        exact = length <= EXACT_REACH[0] and branch_cosine <= EXACT_REACH[1]
        if not (exact or (seeds and length <= SEED_REACH[0] and branch_cosine <= SEED_REACH[1])):
            return _NANS, False, False  # out of reach, whatever its joints
        offsets, terms = self._offsets_f, self._unmap_terms
        model = branch if offsets is None else [a - o for a, o in zip(branch, offsets)]
        if terms is not None:
            model = [_combine_one(row, model) for row in terms]
        # nearest_equivalent_one, with the check against the limits without the seed margin
        # in the same pass.
        turned, inside, strict = [], True, True
        try:
            for value, reference_value, (low, high, strict_low, strict_high, turns) in zip(
                    model, near, self._joint_limits_f[seeds]):
                if turns:
                    value = value + TWO_PI * round((reference_value - value) * INVERSE_TWO_PI)
                    if value < low:
                        value += TWO_PI
                    if value > high:
                        value -= TWO_PI
                if not low <= value <= high:
                    inside = False
                if not strict_low <= value <= strict_high:
                    strict = False
                turned.append(value)
        except (ValueError, OverflowError):  # round() of a NaN or an infinity
            raise one.Degenerate("an angle that is not finite") from None
        if seeds:
            ok, best = inside, exact and strict
        else:
            ok = best = exact and inside
        return (turned if ok else _NANS), ok, best

    def _controller_joints(self, angles):
        """Exponential angles (6, ...) -> controller joints (6, ...)."""
        model = [angles[i] - self._offsets[i] for i in range(6)]
        return np.stack([_combine(self._unmap[i], model) for i in range(6)])


def flip_coefficients(u, w5, w6):
    """(a, b, offset) with u · R5(t) w6 = a cos t + b sin t + offset, for unit vectors (3,):
    the condition that gives joint 5 (the "wrist flip") in both solvers, from Rodrigues'
    formula R5(t) w6 = w6 cos t + (w5 x w6) sin t + w5 (w5 · w6)(1 - cos t)."""
    return (u @ w6 - (u @ w5) * (w5 @ w6), u @ np.cross(w5, w6), (u @ w5) * (w5 @ w6))


def _triple(v):
    return tuple(float(x) for x in v)


def _reach(length_excess, cosine_excess, tolerances):
    """(8, B) mask of branches within reach, given the excesses from :meth:`_angles`."""
    ok = (length_excess <= tolerances[0]) & (cosine_excess <= tolerances[1])
    return np.broadcast_to(ok, (2, 2, 2, ok.shape[-1])).reshape(8, -1)


def _combine_one(terms, values):
    """:func:`_combine` on floats, for the nonzero ``terms`` [(index, coefficient)]: the same
    additions in the same order."""
    total = None
    for index, coef in terms:
        value = values[index]
        term = value if coef == 1.0 else -value if coef == -1.0 else coef * value
        total = term if total is None else total + term
    return 0.0 if total is None else total


def _combine(coefficients, arrays):
    """sum_k coefficients[k] * arrays[k], skipping zero coefficients and unit multiplications."""
    total = 0.0
    for coef, array in zip(coefficients, arrays):
        if coef == 0.0:
            continue
        term = array if coef == 1.0 else -array if coef == -1.0 else coef * array
        total = term if np.isscalar(total) else total + term
    return total
