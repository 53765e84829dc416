"""Joint limits of joints that turn: a revolute joint whose value may change by whole turns
without changing the pose lives on a circle, and its limits cut an arc out of that circle.

Both solvers need this: the closed forms pick, among a joint's 2 pi equivalents, the one
within the limits nearest to a posture hint; the numerical solver projects its iterates onto
the arc (wrapping by whole turns before clipping), so that an iterate crossing +-pi, or
approaching a limit from a side where a whole turn brings it back inside, keeps moving.
"""
import numpy as np

TWO_PI = 2.0 * np.pi
INVERSE_TWO_PI = 1.0 / TWO_PI
# Rounding allowance at the limits (rad, mm).
LIMIT_TOL = 1e-9


def periodic_joints(chain):
    """Mask of joints whose value may change by 2 pi without changing the pose: revolute
    joints that enter the model joints with integer coefficients."""
    jm = chain.joint_map
    integer = np.all(np.abs(jm - np.round(jm)) < 1e-12, axis=0)
    touches_prismatic = np.any((jm != 0.0) & ~chain.revolute[:, None], axis=0)
    return chain.revolute & integer & ~touches_prismatic


def nearest_equivalent(q, reference, lower, upper, periodic):
    """Periodic joints moved by whole turns to the equivalent nearest ``reference`` among
    those within [lower, upper]; all arguments broadcast together.  Returns the joints and an
    elementwise mask of values within the limits (no equivalent fits where it is False)."""
    turned = q + TWO_PI * np.rint((reference - q) * (1.0 / TWO_PI))
    # The nearest equivalent lies within half a turn of the reference; if that one is beyond
    # a limit, the only candidate left is the one a turn back inside.
    turned += TWO_PI * (turned < lower)
    turned -= TWO_PI * (turned > upper)
    if not np.all(periodic):
        turned = np.where(periodic, turned, q)
    return turned, (turned >= lower) & (turned <= upper)


def nearest_equivalent_one(q, reference, lower, upper, periodic):
    """:func:`nearest_equivalent` of one configuration on Python floats (sequences of n:
    joints, reference, limits, periodic flags), with the same operations in the same order.
    Returns the joints (a list) and whether every one is within its limits.  Raises
    ValueError or OverflowError for a joint or reference that is not finite."""
    out = []
    inside = True
    for value, near, low, high, turns in zip(q, reference, lower, upper, periodic):
        if turns:
            value = value + TWO_PI * round((near - value) * INVERSE_TWO_PI)
            if value < low:
                value += TWO_PI
            if value > high:
                value -= TWO_PI
        if not low <= value <= high:
            inside = False
        out.append(value)
    return out, inside


class JointLimits:
    """A chain's limits, with the projection the numerical solver applies to its iterates."""

    def __init__(self, chain):
        self.lower = chain.lower
        self.upper = chain.upper
        self.periodic = periodic_joints(chain)
        self._wrapping = bool(np.any(self.periodic & (np.isfinite(self.lower) | np.isfinite(self.upper))))

    def project(self, q):
        """The nearest point of the feasible set to each row of ``q`` (N, n) (``q`` itself
        when every row is feasible).

        A periodic joint beyond a limit first goes back by whole turns, as few as needed to
        pass that limit; if that lands beyond the other limit (the arc does not cover the
        circle) it goes to whichever limit is closer around the circle.  Other joints clip.
        """
        lower, upper = self.lower, self.upper
        if not self._wrapping:
            return np.clip(q, lower, upper)
        outside = np.flatnonzero(np.any((q < lower) | (q > upper), axis=1))
        if outside.size == 0:
            return q
        q = q.copy()
        q[outside] = self._wrap(q[outside])
        return q

    def _wrap(self, q):
        """:meth:`project` for rows with a joint beyond a limit."""
        lower, upper = self.lower, self.upper
        with np.errstate(invalid="ignore"):  # infinite limits: inf - inf in unused branches
            above, below = q > upper, q < lower
            shifted = np.where(above, q - TWO_PI * np.ceil((q - upper) * (1.0 / TWO_PI)),
                               np.where(below, q + TWO_PI * np.ceil((lower - q) * (1.0 / TWO_PI)), q))
            gap = (shifted < lower) | (shifted > upper)
            # Angle past the upper limit, going up, in [0, 2 pi).
            past_upper = np.mod(q - upper, TWO_PI)
            closer_upper = past_upper <= (lower + TWO_PI - upper) - past_upper
            circular = np.where(gap, np.where(closer_upper, upper, lower), shifted)
        return np.where(self.periodic, circular, np.clip(q, lower, upper))

    def within(self, q):
        """(N,) mask of rows of ``q`` within the limits (with rounding allowance)."""
        return np.all((q >= self.lower - LIMIT_TOL) & (q <= self.upper + LIMIT_TOL), axis=-1)
